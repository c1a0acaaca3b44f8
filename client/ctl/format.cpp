// SPDX-License-Identifier: Apache-2.0
#include "format.hpp"

#include "duration/duration.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>

namespace drivebus::ctl {
namespace {

std::string lower(std::string_view text) {
    std::string out(text);
    std::ranges::transform(out, out.begin(),
                           [](char c) { return static_cast<char>(std::tolower(static_cast<unsigned char>(c))); });
    return out;
}

std::string_view trim(std::string_view text) {
    while (!text.empty() && std::isspace(static_cast<unsigned char>(text.front())) != 0) {
        text.remove_prefix(1);
    }
    while (!text.empty() && std::isspace(static_cast<unsigned char>(text.back())) != 0) {
        text.remove_suffix(1);
    }
    return text;
}

// Splits "30.5 Hz" into the number and the rest ("30.5", "Hz").
std::pair<std::string_view, std::string_view> split_number(std::string_view text) {
    std::size_t i = 0;
    if (i < text.size() && (text[i] == '-' || text[i] == '+')) {
        ++i;
    }
    if (text.substr(i).starts_with("0x") || text.substr(i).starts_with("0X")) {
        i += 2;
        while (i < text.size() && std::isxdigit(static_cast<unsigned char>(text[i])) != 0) {
            ++i;
        }
    } else {
        while (i < text.size() && (std::isdigit(static_cast<unsigned char>(text[i])) != 0 || text[i] == '.')) {
            ++i;
        }
        // An exponent only when digits follow: "1e3", not the "e" of a unit.
        if (i + 1 < text.size() && (text[i] == 'e' || text[i] == 'E') &&
            std::isdigit(static_cast<unsigned char>(text[i + 1])) != 0) {
            ++i;
            while (i < text.size() && std::isdigit(static_cast<unsigned char>(text[i])) != 0) {
                ++i;
            }
        }
    }
    return {text.substr(0, i), trim(text.substr(i))};
}

std::optional<long long> parse_integer(std::string_view text) {
    bool negative = false;
    if (!text.empty() && (text.front() == '-' || text.front() == '+')) {
        negative = text.front() == '-';
        text.remove_prefix(1);
    }
    int base = 10;
    if (text.size() > 2 && text[0] == '0' && (text[1] == 'x' || text[1] == 'X')) {
        text.remove_prefix(2);
        base = 16;
    }
    if (text.empty()) {
        return std::nullopt;
    }
    unsigned long long value = 0;
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value, base);
    if (ec != std::errc{} || end != text.data() + text.size() || value > 0xFFFFFULL) {
        return std::nullopt;
    }
    const auto v = static_cast<long long>(value);
    return negative ? -v : v;
}

std::optional<double> parse_real(std::string_view text) {
    if (!text.empty() && text.front() == '+') {
        text.remove_prefix(1);
    }
    double value = 0;
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
    if (text.empty() || ec != std::errc{} || end != text.data() + text.size() || !std::isfinite(value)) {
        return std::nullopt;
    }
    return value;
}

// A raw number as the register's 16-bit word: 0..65535, or -32768..32767 for a signed one.
std::expected<std::uint16_t, std::string> to_word(long long value, const RegisterInfo* info, std::string_view text) {
    const bool is_signed = info != nullptr && info->is_signed;
    if (value < 0 && !is_signed) {
        return std::unexpected(fmt::format("'{}' is negative, and {} is not a signed register", text,
                                           info != nullptr ? info->name : std::string("this")));
    }
    if (value < -32768 || value > 65535 || (is_signed && value > 32767)) {
        return std::unexpected(fmt::format("'{}' does not fit in a 16-bit register{}", text,
                                           is_signed ? " (signed: -32768..32767)" : " (0..65535)"));
    }
    return static_cast<std::uint16_t>(value < 0 ? value + 65536 : value);
}

}  // namespace

int exit_code(ErrorKind kind) noexcept {
    switch (kind) {
    case ErrorKind::Exception:
    case ErrorKind::Timeout:
    case ErrorKind::LateReply:
    case ErrorKind::BadFrame: return kExitDrive;
    case ErrorKind::InvalidArgument: return kExitUsage;
    case ErrorKind::Rejected:
    case ErrorKind::Unsupported: return kExitRejected;
    case ErrorKind::NotPermitted: return kExitNotPermitted;
    case ErrorKind::NotRunning:
    case ErrorKind::NoSuchBus:
    case ErrorKind::BusDown:
    case ErrorKind::DaemonGone: return kExitUnavailable;
    case ErrorKind::QueueFull: return kExitQueueFull;
    case ErrorKind::Withdrawn: return kExitWithdrawn;
    case ErrorKind::Expired: return kExitExpired;
    case ErrorKind::NoReply:
    case ErrorKind::OutcomeUnknown: return kExitUnknown;
    }
    return kExitDrive;
}

std::string kind_name(ErrorKind kind) {
    std::string name(to_string(kind));
    std::ranges::replace(name, ' ', '_');
    return name;
}

std::string rejection_hint(const Error& error, const Profile* profile, std::string_view what, std::uint16_t start,
                           std::size_t count) {
    if (error.kind != ErrorKind::Rejected || profile == nullptr) {
        return {};
    }
    // The register a rejection is about is `start` only when there is one.
    const auto* r = count == 1 ? profile->find(start) : nullptr;
    switch (error.reason) {
    case shm::RejectReason::UnknownRegister:
        return fmt::format("profile {} does not list it (its registers: {}.toml)", profile->type, profile->type);
    case shm::RejectReason::ReadOnly: return r != nullptr ? fmt::format("{} can only be read", r->name) : std::string();
    case shm::RejectReason::WriteOnly:
        return r != nullptr ? fmt::format("{} can only be written", r->name) : std::string();
    case shm::RejectReason::Quantity: {
        const auto most = what == "write" ? profile->functions.write_multiple_max : profile->functions.read_holding_max;
        return fmt::format("profile {} {} at most {} register{} per request", profile->type,
                           what == "write" ? "writes" : "reads", most, most == 1 ? "" : "s");
    }
    case shm::RejectReason::ValueOutOfRange: {
        if (r == nullptr) {
            return {};
        }
        const auto lo = r->min.value_or(r->is_signed ? -32768 : 0);
        const auto hi = r->max.value_or(r->is_signed ? 32767 : 65535);
        auto text = fmt::format("{} takes {}..{}", r->name, lo, hi);
        if (has_engineering(*r)) {
            const int places = decimals(r->scale);
            text += fmt::format(" ({:.{}f}-{:.{}f}{}{})", lo * r->scale, places, hi * r->scale, places,
                                r->unit.empty() ? "" : " ", r->unit);
        }
        return text;
    }
    case shm::RejectReason::Unsupported:
        return what == "identify" ? fmt::format("profile {} has no device identification (FC43/14)", profile->type)
                                  : std::string();
    default: return {};
    }
}

std::expected<std::chrono::milliseconds, std::string> option_duration(std::string_view text) {
    const auto d = drivebus::parse_duration(text);
    if (!d) {
        return std::unexpected(fmt::format("'{}' {}", text, d.error()));
    }
    const auto ms = std::chrono::ceil<std::chrono::milliseconds>(*d);
    if (ms < std::chrono::milliseconds(1) || ms > std::chrono::hours(24)) {
        return std::unexpected(fmt::format("duration '{}' is outside 1ms-24h", text));
    }
    return ms;
}

std::string format_age(std::int64_t ns) {
    if (ns < 0) {
        ns = 0;
    }
    const auto ms = ns / 1'000'000;
    if (ms < 1000) {
        return fmt::format("{} ms", ms);
    }
    if (ms < 60'000) {
        return fmt::format("{:.1f} s", static_cast<double>(ms) / 1000.0);
    }
    if (ms < 3'600'000) {
        return fmt::format("{} min", ms / 60'000);
    }
    return fmt::format("{} h", ms / 3'600'000);
}

std::string hex(std::uint16_t value) {
    return fmt::format("0x{:04X}", value);
}

int decimals(double scale) noexcept {
    for (int d = 0; d < 6; ++d) {
        const double shifted = scale * std::pow(10.0, d);
        if (std::fabs(shifted - std::round(shifted)) < 1e-9 * std::max(1.0, shifted)) {
            return d;
        }
    }
    return 6;
}

double engineering(const RegisterInfo& info, std::uint16_t raw) noexcept {
    const double value = info.to_engineering(raw);
    const double factor = std::pow(10.0, decimals(info.scale));
    return std::round(value * factor) / factor;
}

bool has_engineering(const RegisterInfo& info) noexcept {
    return !info.unit.empty() || info.scale != 1.0 || info.is_signed;
}

std::string format_engineering(const RegisterInfo& info, std::uint16_t raw) {
    if (!has_engineering(info)) {
        return {};
    }
    auto text = fmt::format("{:.{}f}", engineering(info, raw), decimals(info.scale));
    if (!info.unit.empty()) {
        text += " " + info.unit;
    }
    return text;
}

std::vector<std::string> set_bits(const RegisterInfo& info, std::uint16_t raw) {
    std::vector<std::string> out;
    for (const auto& [bit, meaning] : info.bits) {
        if (bit < 16 && ((static_cast<unsigned>(raw) >> bit) & 1U) != 0) {
            const auto colon = meaning.find(':');
            out.push_back(fmt::format("{} {}", bit, colon == std::string::npos ? meaning : meaning.substr(0, colon)));
        }
    }
    return out;
}

std::string value_meaning(const RegisterInfo& info, std::uint16_t raw) {
    const std::int32_t key = info.is_signed ? static_cast<std::int16_t>(raw) : static_cast<std::int32_t>(raw);
    const auto it = info.values.find(key);
    return it == info.values.end() ? std::string() : it->second;
}

std::vector<std::string> register_columns(std::uint16_t address, std::uint16_t raw, const RegisterInfo* info) {
    if (info == nullptr) {
        return {"-", hex(address), std::to_string(raw), "", ""};
    }
    auto value = format_engineering(*info, raw);
    if (const auto meaning = value_meaning(*info, raw); !meaning.empty()) {
        value += (value.empty() ? "" : " ") + ("(" + meaning + ")");
    }
    return {info->name, hex(address), std::to_string(raw), value, info->title};
}

std::expected<std::uint16_t, std::string> parse_value(std::string_view text, const RegisterInfo* info) {
    const auto whole = trim(text);
    const auto [number, unit] = split_number(whole);
    if (number.empty() || number == "-" || number == "+") {
        return std::unexpected(fmt::format("'{}' is not a value (a raw number like 300 or 0x12C{})", text,
                                           info != nullptr && !info->unit.empty()
                                               ? fmt::format(", or {} with its unit like 30{}", info->name, info->unit)
                                               : std::string()));
    }
    const bool hex_number = number.find('x') != std::string_view::npos || number.find('X') != std::string_view::npos;
    if (unit.empty()) {
        if (const auto n = parse_integer(number)) {
            return to_word(*n, info, whole);
        }
        if (info != nullptr && !info->unit.empty() && parse_real(number)) {
            return std::unexpected(fmt::format("'{}' is not a raw value of {}: give it with its unit ({} {})", text,
                                               info->name, number, info->unit));
        }
        return std::unexpected(fmt::format("'{}' is not a raw value (decimal or 0x hex)", text));
    }
    if (info == nullptr) {
        return std::unexpected(
            fmt::format("'{}' has a unit, but the register is not in the drive's profile: give a "
                        "raw value",
                        text));
    }
    if (info->unit.empty()) {
        return std::unexpected(
            fmt::format("{} has no unit in the drive's profile: give a raw value, not '{}'", info->name, text));
    }
    if (lower(unit) != lower(info->unit)) {
        return std::unexpected(fmt::format("{} is in {}, not {}", info->name, info->unit, unit));
    }
    const auto value = hex_number ? std::nullopt : parse_real(number);
    if (!value) {
        return std::unexpected(fmt::format("'{}' is not a number of {}", number, info->unit));
    }
    const double exact = *value / info->scale;
    const double raw = std::round(exact);
    if (std::fabs(raw - exact) > 1e-6) {
        return std::unexpected(fmt::format("{} {} is finer than {}'s step of {} {}", number, info->unit, info->name,
                                           info->scale, info->unit));
    }
    if (raw < -32768.0 || raw > 65535.0) {
        return std::unexpected(fmt::format("{} does not fit in register {}", text, info->name));
    }
    return to_word(static_cast<long long>(raw), info, whole);
}

std::vector<std::string> join_units(const std::vector<std::string>& args) {
    std::vector<std::string> out;
    for (const auto& a : args) {
        const bool starts_number = !a.empty() && (std::isdigit(static_cast<unsigned char>(a.front())) != 0 ||
                                                  a.front() == '-' || a.front() == '+' || a.front() == '.');
        if (!starts_number && !out.empty() && !a.empty()) {
            out.back() += " " + a;
        } else {
            out.push_back(a);
        }
    }
    return out;
}

}  // namespace drivebus::ctl
