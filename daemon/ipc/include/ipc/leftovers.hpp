// SPDX-License-Identifier: Apache-2.0
// What iceoryx processes that did not stop cleanly leave behind in /tmp and /dev/shm.
//
// A RouDi that is killed leaves its lock, its socket and its segments; an embedded RouDi
// replaces them, unless they belong to another user: /tmp and /dev/shm are sticky, so only
// their owner may remove them, and iceoryx then fails with a raw line of its own. A client
// that is killed leaves its socket /tmp/<name>-<pid> and its lock /tmp/<name>-<pid>.lock,
// which nothing ever removes.
#pragma once

#include <optional>
#include <string>
#include <vector>

namespace drivebus::ipc {

// Before a RouDi is embedded (none answers): what would stop it, in one line that says what to
// do; nullopt when nothing does. Either a RouDi that holds its lock but does not answer (it is
// starting, or hangs), or files of a dead RouDi that this process may not replace, named with
// what to remove. `segments` are the names of the payload segments (/dev/shm/<name>).
[[nodiscard]] std::optional<std::string> roudi_in_the_way(const std::vector<std::string>& segments);

// Removes the sockets (and locks) in `dir` of iceoryx runtimes named as drivebus names them,
// <name>-<pid> with name [A-Za-z0-9_-]{1,60}, whose process is gone and whose lock nobody
// holds (a live runtime holds its lock for as long as it lives). Sockets of other users are
// left alone. Returns the paths removed.
std::vector<std::string> remove_stale_client_sockets(const std::string& dir = "/tmp");

}  // namespace drivebus::ipc
