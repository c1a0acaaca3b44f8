// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: drivebusctl's value, unit and duration parsing (client/ctl/format.*).
// Input: [mode][register][text...]. Mode 0 parses a value for a register of the shipped
// Altivar 21 profile or of a signed test register (chosen by the second byte; some choices give
// no register, as for an address the profile does not list); 1 parses a duration; 2 joins
// units to numbers over '\n'-separated arguments. Checks the parse-print round trips: a value
// accepted for a register prints (as read shows it) back to the same raw word, and the raw word
// itself (decimal, hex; signed registers as negative numbers) parses back to it; an accepted
// duration lies in 1 ms-24 h and "<n>ms" reads back as n; joining units loses no character.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include <fmt/format.h>

#include "format.hpp"
#include "fuzz_support.hpp"

using namespace drivebus;
using fuzz::check;

namespace {

const std::vector<RegisterInfo>& registers() {
    static const std::vector<RegisterInfo> all = [] {
        std::vector<RegisterInfo> out = fuzz::shipped_profile("atv21")->registers;
        RegisterInfo torque;  // signed, with a unit and a scale: none of the shipped registers is signed
        torque.name = "TQ01";
        torque.address = 0x7000;
        torque.unit = "%";
        torque.scale = 0.1;
        torque.is_signed = true;
        torque.min = -2000;
        torque.max = 2000;
        out.push_back(torque);
        return out;
    }();
    return all;
}

void check_value(std::string_view text, const RegisterInfo* info) {
    const auto raw = ctl::parse_value(text, info);
    if (!raw) {
        check(!raw.error().empty(), "a value refused without a reason");
        return;
    }
    const bool is_signed = info != nullptr && info->is_signed;
    const auto number = is_signed ? std::to_string(static_cast<std::int16_t>(*raw)) : std::to_string(*raw);
    const auto again = ctl::parse_value(number, info);
    check(again && *again == *raw, "the raw number does not parse back to its word");
    if (!is_signed) {
        const auto hex = ctl::parse_value(ctl::hex(*raw), info);
        check(hex && *hex == *raw, "the raw word in hex does not parse back to itself");
    }
    if (info != nullptr && !info->unit.empty()) {
        const auto shown = ctl::format_engineering(*info, *raw);
        const auto back = ctl::parse_value(shown, info);
        check(back && *back == *raw, "the value read prints does not parse back to its word");
    }
}

void check_duration(std::string_view text) {
    const auto d = ctl::option_duration(text);
    if (!d) {
        check(!d.error().empty(), "a duration refused without a reason");
        return;
    }
    check(d->count() >= 1 && d->count() <= 24LL * 3600 * 1000, "a duration outside 1ms-24h");
    const auto back = ctl::option_duration(fmt::format("{}ms", d->count()));
    check(back && *back == *d, "a duration in ms does not parse back");
}

void check_join(std::string_view text) {
    std::vector<std::string> args;
    std::size_t characters = 0;
    while (true) {
        const auto newline = text.find('\n');
        args.emplace_back(text.substr(0, newline));
        characters += args.back().size();
        if (newline == std::string_view::npos) {
            break;
        }
        text.remove_prefix(newline + 1);
    }
    const auto joined = ctl::join_units(args);
    check(joined.size() <= args.size(), "joining made more arguments");
    std::size_t after = 0;
    for (const auto& a : joined) {
        after += a.size();
    }
    // Each join adds one space.
    check(after == characters + (args.size() - joined.size()), "joining lost or added characters");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size < 2) {
        return 0;
    }
    const std::string_view text(reinterpret_cast<const char*>(data + 2), size - 2);
    switch (data[0] % 3) {
    case 0: {
        const auto& all = registers();
        // One choice in four is no register: a raw address the profile does not name.
        const std::size_t pick = data[1] % (all.size() + all.size() / 3 + 1);
        check_value(text, pick < all.size() ? &all[pick] : nullptr);
        break;
    }
    case 1: check_duration(text); break;
    default: check_join(text); break;
    }
    return 0;
}
