// SPDX-License-Identifier: Apache-2.0
// parse_profile(): the TOML text, its tables, then the checks that span tables.
#include <algorithm>
#include <limits>
#include <map>

#include "drivebus/profile.hpp"
#include "parse_sections.hpp"

namespace drivebus {
namespace {

using profile_detail::entry_name;
using profile_detail::Errors;
using profile_detail::hex4;
using profile_detail::in_quotes;
using profile_detail::Need;
using profile_detail::Section;

std::string lower(std::string_view text) {
    std::string out(text);
    std::ranges::transform(out, out.begin(),
                           [](char c) { return c >= 'A' && c <= 'Z' ? static_cast<char>(c + 32) : c; });
    return out;
}

void read_tables(const toml::table& root, Errors& errors, Profile& profile) {
    Section s(root, "", errors);
    s.allow_only({"schema", "drive", "functions", "identification", "indirect_block", "register", "fault_code",
                  "control", "safety"});
    const auto schema = s.integer("schema", std::numeric_limits<std::int64_t>::min(),
                                  std::numeric_limits<std::int64_t>::max(), Need::Required);
    if (schema && *schema != 1) {
        s.fail("schema " + std::to_string(*schema) + " is not supported (this version reads schema 1)");
    }
    if (const auto* drive = s.table("drive", Need::Required)) {
        profile_detail::read_drive(*drive, errors, profile);
    }
    if (const auto* functions = s.table("functions")) {
        profile_detail::read_functions(*functions, errors, profile.functions);
    }
    if (const auto* identification = s.table("identification")) {
        profile_detail::read_identification(*identification, errors, profile.identification.emplace());
        if (!profile.functions.device_identification) {
            errors.add("identification", "present, but functions.device_identification is not true");
        }
    }
    if (const auto* control = s.table("control")) {
        profile_detail::read_control(*control, errors, profile.control.emplace());
    }
    if (const auto* safety = s.table("safety")) {
        profile_detail::read_safety(*safety, errors, profile.safety.emplace());
    }
    const auto registers = s.tables("register");
    for (std::size_t i = 0; i < registers.size(); ++i) {
        profile.registers.push_back(profile_detail::read_register(*registers[i], i, errors));
    }
    const auto blocks = s.tables("indirect_block");
    for (std::size_t i = 0; i < blocks.size(); ++i) {
        profile.indirect_blocks.push_back(profile_detail::read_block(*blocks[i], i, errors));
    }
    const auto faults = s.tables("fault_code");
    for (std::size_t i = 0; i < faults.size(); ++i) {
        profile.fault_codes.push_back(profile_detail::read_fault_code(*faults[i], i, errors));
    }
}

void check_registers(const Profile& profile, Errors& errors) {
    std::map<std::string, const RegisterInfo*> names;
    std::map<std::uint16_t, const RegisterInfo*> addresses;
    for (const auto& r : profile.registers) {
        const auto where = "register " + r.name;
        if (const auto [it, fresh] = names.emplace(lower(r.name), &r); !fresh) {
            errors.add(where, "name repeats register " + it->second->name + " (names are case-insensitive)");
        }
        if (!r.address) {
            continue;
        }
        if (const auto [it, fresh] = addresses.emplace(*r.address, &r); !fresh) {
            errors.add(where, "address " + hex4(*r.address) + " is already register " + it->second->name);
        }
    }
}

void check_fault_codes(const Profile& profile, Errors& errors) {
    std::map<std::uint16_t, std::size_t> codes;
    for (std::size_t i = 0; i < profile.fault_codes.size(); ++i) {
        const auto code = profile.fault_codes[i].code;
        if (const auto [it, fresh] = codes.emplace(code, i); !fresh) {
            errors.add("fault_code " + std::to_string(code),
                       "code " + std::to_string(code) + " is also " + entry_name("fault_code", it->second));
        }
    }
}

// The control section names registers of the profile, in their spelling; the command and
// reference registers must be writable.
void check_control(Profile& profile, Errors& errors) {
    if (!profile.control) {
        return;
    }
    auto& c = *profile.control;
    const auto fix = [&](std::string& name, std::string_view key, bool must_write) {
        if (name.empty()) {
            return;
        }
        const auto* r = profile.find(name);
        if (r == nullptr) {
            errors.add("control", std::string(key) + " " + in_quotes(name) + " is not a register of this profile");
            return;
        }
        if (must_write && !writable(r->access)) {
            errors.add("control", std::string(key) + " " + in_quotes(name) + " is not writable");
        }
        name = r->name;
    };
    fix(c.command, "command", true);
    fix(c.reference, "reference", true);
    fix(c.status, "status", false);
    fix(c.output_frequency, "output_frequency", false);
    fix(c.fault, "fault", false);
    fix(c.alarm, "alarm", false);
    for (auto& name : c.lease_registers) {
        fix(name, "lease_registers", true);
    }
}

// Selectors and choices must name registers of the profile; they take the register's spelling.
void check_blocks(Profile& profile, Errors& errors) {
    std::map<std::uint8_t, std::size_t> functions;
    for (std::size_t i = 0; i < profile.indirect_blocks.size(); ++i) {
        auto& block = profile.indirect_blocks[i];
        const auto where = entry_name("indirect_block", i);
        if (const auto [it, fresh] = functions.emplace(block.function, i); !fresh) {
            errors.add(where, "function " + std::to_string(block.function) + " already has a block (" +
                                  entry_name("indirect_block", it->second) + ")");
        }
        for (std::size_t k = 0; k < block.selectors.size(); ++k) {
            const auto* r = profile.find(block.selectors[k]);
            if (r == nullptr) {
                errors.add(where, "selectors[" + std::to_string(k) + "] " + in_quotes(block.selectors[k]) +
                                      " is not a register of this profile");
                continue;
            }
            block.selectors[k] = r->name;
        }
        for (auto& [value, name] : block.choices) {
            const auto* r = profile.find(name);
            if (r == nullptr) {
                errors.add(where, "choices." + std::to_string(value) + " " + in_quotes(name) +
                                      " is not a register of this profile");
                continue;
            }
            name = r->name;
        }
    }
}

}  // namespace

std::expected<Profile, ProfileError> parse_profile(std::string_view text, std::string_view source) {
    auto root = settings::parse_toml(text, source);
    if (!root) {
        return std::unexpected(ProfileError{std::move(root.error())});
    }
    Errors errors(source);
    Profile profile;
    read_tables(*root, errors, profile);
    if (!errors.any()) {
        check_registers(profile, errors);
        check_fault_codes(profile, errors);
        check_blocks(profile, errors);
        check_control(profile, errors);
        profile_detail::check_safety(profile, errors);
    }
    if (errors.any()) {
        return std::unexpected(ProfileError{errors.message()});
    }
    return profile;
}

}  // namespace drivebus
