// SPDX-License-Identifier: Apache-2.0
// drivebusctl run by root (sudo drivebusctl list). iceoryx maps a process's shared memory by
// the groups of its *user*, and RouDi answers it through a socket the process makes with its
// effective group: root, in none of drivebus's groups, could neither watch nor be answered.
// So, before it connects, drivebusctl run by root becomes an ordinary user when the RouDi does
// not run as root: the user who ran sudo (SUDO_USER), or else the RouDi's own user (drivebusd's,
// which may watch but not send requests), with that user's groups and the RouDi's group as its
// effective group. Only the commands that connect to drivebusd do this.
#pragma once

#include <sys/types.h>
#include <expected>
#include <string>

namespace drivebus::ctl {

struct Identity {
    std::string user;
    uid_t uid = 0;
    gid_t group = 0;  // the effective group: the RouDi socket's
};

// Whom root acts as, given the RouDi socket's owner and group and SUDO_USER (empty when not
// set); nullopt-like error text when there is nobody to become. Pure but for the user database.
[[nodiscard]] std::expected<Identity, std::string> identity_for_root(uid_t roudi_owner, gid_t roudi_group,
                                                                     const std::string& sudo_user);

// Called before connecting: nothing unless this process runs as root and a RouDi that does
// not runs; then becomes identity_for_root() for good (real, effective and saved ids). Once.
// Returns the user it became (empty when it stayed), or why it could not.
[[nodiscard]] std::expected<std::string, std::string> leave_root();

}  // namespace drivebus::ctl
