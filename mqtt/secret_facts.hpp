// SPDX-License-Identifier: Apache-2.0
// What mqtt::secret_problem() judges, read from the system: a file's owner, mode and group
// (stat(2), through symbolic links: the file that is read), and the group's members from the
// account database (its member list and every user whose primary group it is).
#pragma once

#include <expected>
#include <filesystem>
#include <string>

#include "mqtt/secret.hpp"

namespace drivebus::mqtt {

// The account this process runs as (its effective user).
[[nodiscard]] Account this_account();

[[nodiscard]] std::expected<SecretFile, std::string> read_secret_file(std::string key,
                                                                      const std::filesystem::path& path);

}  // namespace drivebus::mqtt
