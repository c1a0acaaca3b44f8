// SPDX-License-Identifier: Apache-2.0
// Facts of this machine that the daemon, libdrivebus and the tests all ask: whether a local
// socket answers (iceoryx's RouDi listens on /tmp/roudi), and the groups of this user.
#pragma once

#include <expected>
#include <string>
#include <vector>

#include "sys/posix.hpp"

namespace drivebus::sys {

// Whether a process listens on the Unix datagram socket at `path`: a connect() to it succeeds.
// The error says why not (ENOENT: nobody; ECONNREFUSED: a socket left by a process gone;
// EACCES: not this user's to reach).
[[nodiscard]] std::expected<void, SysError> datagram_socket_answers(const std::string& path);

// The groups of this process's effective user as the group database lists them (its primary
// group and every group it is a member of): what RouDi and the segments' ACLs go by, not the
// groups this process happens to carry.
[[nodiscard]] std::vector<std::string> groups_of_this_user();

// Whether this user is in group `name` (as groups_of_this_user() counts), or the process's
// effective group is it.
[[nodiscard]] bool user_in_group(const std::string& name);

}  // namespace drivebus::sys
