// SPDX-License-Identifier: Apache-2.0
// Readers of a profile's tables. Each checks what lies inside its own table; parse.cpp checks
// what spans several (duplicates, names that blocks refer to). Internal to lib/profile/.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

#include "drivebus/profile.hpp"
#include "settings/reader.hpp"

namespace drivebus::profile_detail {

using settings::Errors;
using settings::hex4;
using settings::in_quotes;
using settings::key_integer;
using settings::Need;
using settings::number_text;
using settings::read_small_file;
using settings::Section;

void read_drive(const toml::table& table, Errors& errors, Profile& profile);
void read_functions(const toml::table& table, Errors& errors, FunctionSupport& functions);
void read_control(const toml::table& table, Errors& errors, ControlInfo& control);
void read_identification(const toml::table& table, Errors& errors, Identification& identification);
void read_safety(const toml::table& table, Errors& errors, SafetyInfo& safety);
// The registers [safety] names, against the profile's (parse_safety.cpp).
void check_safety(Profile& profile, Errors& errors);
// `index` counts from 0 and names an entry in errors until its name (or code) is known.
[[nodiscard]] RegisterInfo read_register(const toml::table& table, std::size_t index, Errors& errors);
[[nodiscard]] IndirectBlock read_block(const toml::table& table, std::size_t index, Errors& errors);
[[nodiscard]] FaultCode read_fault_code(const toml::table& table, std::size_t index, Errors& errors);

// "indirect_block #2": how errors name an entry of an array of tables, counting from 1.
[[nodiscard]] std::string entry_name(std::string_view array, std::size_t index);
// A drive type, which is also a file name: [a-z0-9_-]+.
[[nodiscard]] bool valid_type_name(std::string_view name) noexcept;

}  // namespace drivebus::profile_detail
