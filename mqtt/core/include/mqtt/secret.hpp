// SPDX-License-Identifier: Apache-2.0
// The broker's secrets (the password file, the TLS client key), judged before the bridge uses
// them. As ssh refuses a private key that others can read, the bridge refuses a secret that
// anyone but its owner and a group of the bridge's own may read or change. Pure: what the file
// system and the account database say is gathered by the caller (mqtt/secret_facts.cpp).
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace drivebus::mqtt {

struct Account {
    unsigned uid = 0;
    std::string name;  // the user's name, or its number where it has none
};

struct SecretFile {
    std::string key;  // the setting that names it: "broker.password_file"
    std::filesystem::path path;
    Account owner;
    unsigned mode = 0;                       // the permission bits (st_mode & 07777)
    std::string group;                       // the file's group, by name (or number)
    std::vector<std::string> group_members;  // every account in it: as a supplementary or a primary group
};

// Why the bridge, running as `bridge`, must not use `file`; nullopt when it may. Refused:
// - an owner other than root or the bridge's own user;
// - any permission for others (mode o+r, o+w or o+x);
// - any permission for a group that has a member besides the bridge's user (and root). Run as
//   root (--check-config by an administrator), a group of one account is taken as the
//   service's own: root:drivebus-mqtt 0640 passes there too.
[[nodiscard]] std::optional<std::string> secret_problem(const SecretFile& file, const Account& bridge);

}  // namespace drivebus::mqtt
