// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: the profile reader on arbitrary text. A refused profile gets one line naming
// it; an accepted one is what every reader of profiles relies on: names and addresses unique
// (look-ups find the register itself, in any case), min <= default <= max, and every raw value in
// range converts to its engineering value and back to the same raw word.
#include <algorithm>
#include <cctype>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "fuzz_support.hpp"

using namespace drivebus;
using fuzz::check;

namespace {

std::string upper(std::string_view text) {
    std::string out(text);
    std::ranges::transform(out, out.begin(),
                           [](char c) { return c >= 'a' && c <= 'z' ? static_cast<char>(c - 32) : c; });
    return out;
}

// The raw words of a register's range worth converting: its ends, its default, and a few inside.
void check_conversions(const RegisterInfo& r) {
    const std::int32_t lo = r.min.value_or(r.is_signed ? -32768 : 0);
    const std::int32_t hi = r.max.value_or(r.is_signed ? 32767 : 65535);
    check(lo <= hi, "min above max");
    for (const std::int32_t n : {lo, hi, lo + (hi - lo) / 2, r.default_value.value_or(lo)}) {
        check(n >= lo && n <= hi, "default outside min..max");
        const auto raw = static_cast<std::uint16_t>(n);
        check(r.in_range(raw), "a value of min..max is out of range");
        const auto back = r.from_engineering(r.to_engineering(raw));
        check(back.has_value() && *back == raw, "raw -> engineering -> raw changed the word");
    }
}

void check_profile(const Profile& p) {
    check(p.address_min >= 1 && p.address_min <= p.address_max && p.address_max <= 247, "address range in 1-247");
    for (const auto& r : p.registers) {
        check(p.find(r.name) == &r, "look-up by name finds another register");
        check(p.find(upper(r.name)) == &r, "look-up by name depends on case");
        if (r.address) {
            check(p.find(*r.address) == &r, "look-up by address finds another register");
        }
        check(r.scale > 0.0, "scale above 0");
        check_conversions(r);
    }
    for (const auto& block : p.indirect_blocks) {
        check(p.block(block.function) == &block, "two indirect blocks for one function");
        check(block.min_quantity <= block.max_quantity, "block quantities ordered");
        for (const auto& s : block.selectors) {
            check(p.find(s) != nullptr, "a selector that is not a register");
        }
        for (const auto& [value, name] : block.choices) {
            check(p.find(name) != nullptr, "a choice that is not a register");
        }
    }
    if (p.control) {
        for (const auto& name : p.control->lease_registers) {
            const auto* r = p.find(name);
            check(r != nullptr && writable(r->access), "a lease register that cannot be written");
        }
    }
    if (p.safety && !p.safety->comm_timeout.empty()) {
        const auto* r = p.find(p.safety->comm_timeout);
        check(r != nullptr && r->address && readable(r->access), "a time-out register drivebusd cannot read");
        check(p.safety->comm_timeout_seconds > 0.0, "a time-out unit not above 0");
    }
    for (const auto& f : p.fault_codes) {
        check(p.fault(f.code) == &f, "two fault codes with one number");
    }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string_view text(reinterpret_cast<const char*>(data), size);
    const auto parsed = parse_profile(text, "fuzz.toml");
    if (!parsed) {
        fuzz::check_one_line(parsed.error().message, "a profile error is one line");
        check(parsed.error().message.starts_with("fuzz.toml"), "a profile error names the file");
        return 0;
    }
    check_profile(*parsed);
    return 0;
}
