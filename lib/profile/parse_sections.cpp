// SPDX-License-Identifier: Apache-2.0
// The profile's tables, one reader each: [drive], [functions], [identification],
// [[register]], [[indirect_block]], [[fault_code]].
#include "parse_sections.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <utility>

namespace drivebus::profile_detail {
namespace {

constexpr std::int64_t kMaxBaud = 4'000'000;
constexpr std::array<std::string_view, 3> kParities = {"none", "even", "odd"};
constexpr std::array<std::string_view, 7> kGroups = {"control", "monitoring", "communication", "configuration",
                                                     "fault",   "io",         "identification"};

template <std::size_t N>
bool one_of(const std::array<std::string_view, N>& names, std::string_view name) {
    return std::ranges::find(names, name) != names.end();
}

template <std::size_t N>
std::string listed(const std::array<std::string_view, N>& names) {
    std::string out;
    for (const auto name : names) {
        out.append(out.empty() ? "" : ", ").append(name);
    }
    return out;
}

// Register names are the drives' own ("FA01", "W450"): no spaces, nothing to escape.
bool valid_register_name(std::string_view name) noexcept {
    return !name.empty() && std::ranges::all_of(name, [](char c) {
        return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' || c == '-' ||
               c == '.';
    });
}

std::optional<Access> parse_access(std::string_view text) noexcept {
    if (text == "r") {
        return Access::Read;
    }
    if (text == "w") {
        return Access::Write;
    }
    if (text == "rw") {
        return Access::ReadWrite;
    }
    return std::nullopt;
}

void read_parities(Section& s, Profile& profile) {
    const auto parities = s.strings("parities");
    for (std::size_t i = 0; parities && i < parities->size(); ++i) {
        if (!one_of(kParities, (*parities)[i])) {
            s.fail("parities[" + std::to_string(i) + "] " + in_quotes((*parities)[i]) + " is not one of " +
                   listed(kParities));
        }
        profile.parities.push_back((*parities)[i]);
    }
    if (auto parity = s.string("factory_parity")) {
        if (!one_of(kParities, *parity)) {
            s.fail("factory_parity " + in_quotes(*parity) + " is not one of " + listed(kParities));
        } else if (!profile.parities.empty() &&
                   std::ranges::find(profile.parities, *parity) == profile.parities.end()) {
            s.fail("factory_parity " + in_quotes(*parity) + " is not one of parities");
        }
        profile.factory_parity = std::move(*parity);
    }
}

void read_bauds(Section& s, Profile& profile) {
    for (const auto baud : s.integers("bauds", 1, kMaxBaud).value_or(std::vector<std::int64_t>{})) {
        profile.bauds.push_back(static_cast<std::uint32_t>(baud));
    }
    if (const auto baud = s.integer("factory_baud", 1, kMaxBaud)) {
        const auto value = static_cast<std::uint32_t>(*baud);
        if (!profile.bauds.empty() && std::ranges::find(profile.bauds, value) == profile.bauds.end()) {
            s.fail("factory_baud " + std::to_string(value) + " is not one of bauds");
        }
        profile.factory_baud = value;
    }
}

// min, max and default, in the raw range the register's signedness allows.
void read_range(Section& s, RegisterInfo& r, std::int64_t lo, std::int64_t hi) {
    const auto narrow = [](std::optional<std::int64_t> v) -> std::optional<std::int32_t> {
        return v ? std::optional<std::int32_t>(static_cast<std::int32_t>(*v)) : std::nullopt;
    };
    r.min = narrow(s.integer("min", lo, hi));
    r.max = narrow(s.integer("max", lo, hi));
    r.default_value = narrow(s.integer("default", lo, hi));
    if (r.min && r.max && *r.min > *r.max) {
        s.fail("min " + std::to_string(*r.min) + " is above max " + std::to_string(*r.max));
    }
    if (r.default_value && r.min && *r.default_value < *r.min) {
        s.fail("default " + std::to_string(*r.default_value) + " is below min " + std::to_string(*r.min));
    }
    if (r.default_value && r.max && *r.default_value > *r.max) {
        s.fail("default " + std::to_string(*r.default_value) + " is above max " + std::to_string(*r.max));
    }
}

void read_meanings(Section& s, RegisterInfo& r, std::int64_t lo, std::int64_t hi) {
    for (auto& [bit, meaning] : s.numbered_strings("bits", 0, 15)) {
        r.bits.emplace(static_cast<unsigned>(bit), std::move(meaning));
    }
    for (auto& [value, meaning] : s.numbered_strings("values", lo, hi)) {
        const auto v = static_cast<std::int32_t>(value);
        if (r.min && v < *r.min) {
            s.fail("values key " + std::to_string(v) + " is below min " + std::to_string(*r.min));
        }
        if (r.max && v > *r.max) {
            s.fail("values key " + std::to_string(v) + " is above max " + std::to_string(*r.max));
        }
        r.values.emplace(v, std::move(meaning));
    }
}

}  // namespace

std::string entry_name(std::string_view array, std::size_t index) {
    return std::string(array) + " #" + std::to_string(index + 1);
}

bool valid_type_name(std::string_view name) noexcept {
    return !name.empty() && std::ranges::all_of(name, [](char c) {
        return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' || c == '-';
    });
}

void read_drive(const toml::table& table, Errors& errors, Profile& profile) {
    Section s(table, "drive", errors);
    s.allow_only({"type", "title", "vendor", "address_min", "address_max", "bauds", "parities", "factory_baud",
                  "factory_parity", "data_bits", "stop_bits"});
    if (auto type = s.string("type", Need::Required)) {
        if (!valid_type_name(*type)) {
            s.fail("type " + in_quotes(*type) + " is not made of a-z, 0-9, '_' and '-'");
        }
        profile.type = std::move(*type);
    }
    profile.title = s.string("title").value_or("");
    profile.vendor = s.string("vendor").value_or("");
    const auto first = s.integer("address_min", 1, 247).value_or(1);
    const auto last = s.integer("address_max", 1, 247).value_or(247);
    if (first > last) {
        s.fail("address_min " + std::to_string(first) + " is above address_max " + std::to_string(last));
    }
    profile.address_min = static_cast<std::uint8_t>(first);
    profile.address_max = static_cast<std::uint8_t>(last);
    read_bauds(s, profile);
    read_parities(s, profile);
    if (const auto bits = s.integer("data_bits", 7, 8)) {
        profile.data_bits = static_cast<std::uint8_t>(*bits);
    }
    if (const auto bits = s.integer("stop_bits", 1, 2)) {
        profile.stop_bits = static_cast<std::uint8_t>(*bits);
    }
}

void read_functions(const toml::table& table, Errors& errors, FunctionSupport& functions) {
    Section s(table, "functions", errors);
    s.allow_only({"read_holding_max", "write_multiple_max", "write_single", "broadcast", "device_identification"});
    functions.read_holding_max = static_cast<std::uint16_t>(s.integer("read_holding_max", 1, 125).value_or(125));
    functions.write_multiple_max = static_cast<std::uint16_t>(s.integer("write_multiple_max", 1, 123).value_or(123));
    functions.write_single = s.boolean("write_single").value_or(true);
    const auto codes = s.integers("broadcast", 0, 255).value_or(std::vector<std::int64_t>{});
    for (std::size_t i = 0; i < codes.size(); ++i) {
        const auto code = static_cast<std::uint8_t>(codes[i]);
        const std::string key = "broadcast[" + std::to_string(i) + "] " + std::to_string(code);
        if (code != 6 && code != 16) {
            s.fail(key + ": only functions 6 and 16 may be broadcast");
        } else if (std::ranges::find(functions.broadcast, code) != functions.broadcast.end()) {
            s.fail(key + " is listed twice");
        }
        functions.broadcast.push_back(code);
    }
    functions.device_identification = s.boolean("device_identification").value_or(false);
}

void read_identification(const toml::table& table, Errors& errors, Identification& identification) {
    Section s(table, "identification", errors);
    s.allow_only({"vendor_name", "product_code", "revision"});
    identification.vendor_name = s.string("vendor_name").value_or("");
    identification.product_code = s.string("product_code").value_or("");
    identification.revision = s.string("revision").value_or("");
}

void read_control(const toml::table& table, Errors& errors, ControlInfo& control) {
    Section s(table, "control", errors);
    s.allow_only({"lease_registers", "command", "reference", "status", "output_frequency", "fault", "alarm",
                  "run_forward", "run_reverse", "stop", "freewheel", "fault_reset", "status_bits"});
    control.lease_registers = s.strings("lease_registers").value_or(std::vector<std::string>{});
    control.command = s.string("command").value_or("");
    control.reference = s.string("reference").value_or("");
    control.status = s.string("status").value_or("");
    control.output_frequency = s.string("output_frequency").value_or("");
    control.fault = s.string("fault").value_or("");
    control.alarm = s.string("alarm").value_or("");
    const auto word = [&](std::string_view key) -> std::optional<std::uint16_t> {
        if (const auto v = s.integer(key, 0, 0xFFFF)) {
            return static_cast<std::uint16_t>(*v);
        }
        return std::nullopt;
    };
    control.run_forward = word("run_forward");
    control.run_reverse = word("run_reverse");
    control.stop = word("stop");
    control.freewheel = word("freewheel");
    control.fault_reset = word("fault_reset");
    if (const auto* bits = s.table("status_bits")) {
        Section b(*bits, "control.status_bits", errors);
        b.allow_only({"running", "reverse", "fault", "alarm", "ready"});
        for (const auto* key : {"running", "reverse", "fault", "alarm", "ready"}) {
            if (const auto v = b.integer(key, 0, 15)) {
                control.status_bits[key] = static_cast<unsigned>(*v);
            }
        }
    }
    const bool has_word =
        control.run_forward || control.run_reverse || control.stop || control.freewheel || control.fault_reset;
    if (has_word && control.command.empty()) {
        s.fail("command word values are given, but no command register");
    }
}

RegisterInfo read_register(const toml::table& table, std::size_t index, Errors& errors) {
    Section s(table, entry_name("register", index), errors);
    if (const auto* name = table.get_as<std::string>("name"); name != nullptr && valid_register_name(name->get())) {
        s.rename("register " + name->get());
    }
    s.allow_only({"name", "address", "title", "access", "unit", "scale", "min", "max", "default", "signed", "group",
                  "note", "bits", "values"});
    RegisterInfo r;
    if (auto name = s.string("name", Need::Required)) {
        if (!valid_register_name(*name)) {
            s.fail("name " + in_quotes(*name) + " is not made of letters, digits, '_', '-' and '.'");
        }
        r.name = std::move(*name);
    }
    if (const auto address = s.integer("address", 0, 0xFFFF)) {
        r.address = static_cast<std::uint16_t>(*address);
    }
    r.title = s.string("title").value_or("");
    if (const auto access = s.string("access", Need::Required)) {
        const auto parsed = parse_access(*access);
        if (!parsed) {
            s.fail("access " + in_quotes(*access) + " is not r, w or rw");
        }
        r.access = parsed.value_or(Access::ReadWrite);
    }
    r.unit = s.string("unit").value_or("");
    if (const auto scale = s.number("scale")) {
        if (!std::isfinite(*scale) || *scale <= 0.0) {
            s.fail("scale " + number_text(*scale) + " is not above 0");
        }
        r.scale = *scale;
    }
    r.is_signed = s.boolean("signed").value_or(false);
    const std::int64_t lo = r.is_signed ? -32768 : 0;
    const std::int64_t hi = r.is_signed ? 32767 : 65535;
    read_range(s, r, lo, hi);
    if (auto group = s.string("group")) {
        if (!one_of(kGroups, *group)) {
            s.fail("group " + in_quotes(*group) + " is not one of " + listed(kGroups));
        }
        r.group = std::move(*group);
    }
    r.note = s.string("note").value_or("");
    read_meanings(s, r, lo, hi);
    return r;
}

IndirectBlock read_block(const toml::table& table, std::size_t index, Errors& errors) {
    Section s(table, entry_name("indirect_block", index), errors);
    s.allow_only(
        {"function", "address", "min_quantity", "max_quantity", "selectors", "choices", "selectors_take_effect"});
    IndirectBlock b;
    const auto function = s.integer("function", 0, 255, Need::Required);
    if (function && *function != 3 && *function != 16) {
        s.fail("function " + std::to_string(*function) + " is not 3 (read block) or 16 (write block)");
    }
    b.function = static_cast<std::uint8_t>(function.value_or(3));
    b.address = static_cast<std::uint16_t>(s.integer("address", 0, 0xFFFF, Need::Required).value_or(0));
    const std::int64_t limit = b.function == 16 ? 123 : 125;  // the spec's FC16 and FC03 limits
    const auto least = s.integer("min_quantity", 1, limit, Need::Required).value_or(1);
    const auto most = s.integer("max_quantity", 1, limit, Need::Required).value_or(least);
    if (least > most) {
        s.fail("min_quantity " + std::to_string(least) + " is above max_quantity " + std::to_string(most));
    }
    b.min_quantity = static_cast<std::uint16_t>(least);
    b.max_quantity = static_cast<std::uint16_t>(most);
    b.selectors = s.strings("selectors").value_or(std::vector<std::string>{});
    if (std::cmp_greater(most, b.selectors.size())) {
        s.fail("max_quantity " + std::to_string(most) + " is above the number of selectors (" +
               std::to_string(b.selectors.size()) + ")");
    }
    for (auto& [value, name] : s.numbered_strings("choices", 0, 0xFFFF)) {
        b.choices.emplace(static_cast<std::uint16_t>(value), std::move(name));
    }
    const auto effect = s.string("selectors_take_effect").value_or("at-once");
    if (effect != "at-once" && effect != "after-reset") {
        s.fail("selectors_take_effect \"" + effect + "\" is not \"at-once\" or \"after-reset\"");
    }
    b.selectors_after_reset = effect == "after-reset";
    return b;
}

FaultCode read_fault_code(const toml::table& table, std::size_t index, Errors& errors) {
    Section s(table, entry_name("fault_code", index), errors);
    if (const auto* code = table.get_as<std::int64_t>("code"); code != nullptr) {
        s.rename("fault_code " + std::to_string(code->get()));
    }
    s.allow_only({"code", "name", "title"});
    FaultCode f;
    f.code = static_cast<std::uint16_t>(s.integer("code", 0, 0xFFFF, Need::Required).value_or(0));
    f.name = s.string("name", Need::Required).value_or("");
    f.title = s.string("title").value_or("");
    return f;
}

}  // namespace drivebus::profile_detail
