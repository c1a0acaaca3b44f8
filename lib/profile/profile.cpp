// SPDX-License-Identifier: Apache-2.0
// Register value conversions and profile look-ups.
#include <algorithm>
#include <cmath>

#include "drivebus/profile.hpp"

namespace drivebus {
namespace {

constexpr char ascii_lower(char c) noexcept {
    return c >= 'A' && c <= 'Z' ? static_cast<char>(c + ('a' - 'A')) : c;
}

bool same_name(std::string_view a, std::string_view b) noexcept {
    return std::ranges::equal(a, b, [](char x, char y) { return ascii_lower(x) == ascii_lower(y); });
}

struct RawRange {
    std::int32_t lo;
    std::int32_t hi;
};

// What a word can hold, narrowed by the register's own min and max.
RawRange raw_range(const RegisterInfo& r) noexcept {
    RawRange range = r.is_signed ? RawRange{-32768, 32767} : RawRange{0, 65535};
    if (r.min) {
        range.lo = std::max(range.lo, *r.min);
    }
    if (r.max) {
        range.hi = std::min(range.hi, *r.max);
    }
    return range;
}

std::int32_t as_number(const RegisterInfo& r, std::uint16_t raw) noexcept {
    return r.is_signed ? static_cast<std::int16_t>(raw) : static_cast<std::int32_t>(raw);
}

}  // namespace

double RegisterInfo::to_engineering(std::uint16_t raw) const noexcept {
    return static_cast<double>(as_number(*this, raw)) * scale;
}

std::optional<std::uint16_t> RegisterInfo::from_engineering(double value) const noexcept {
    if (!std::isfinite(value) || !(scale > 0.0)) {
        return std::nullopt;
    }
    const double nearest = std::round(value / scale);
    const auto [lo, hi] = raw_range(*this);
    if (nearest < lo || nearest > hi) {
        return std::nullopt;
    }
    // Negative values become their two's complement word.
    return static_cast<std::uint16_t>(static_cast<std::int32_t>(nearest));
}

bool RegisterInfo::in_range(std::uint16_t raw) const noexcept {
    const auto [lo, hi] = raw_range(*this);
    const std::int32_t value = as_number(*this, raw);
    return value >= lo && value <= hi;
}

const RegisterInfo* Profile::find(std::string_view name) const noexcept {
    const auto it = std::ranges::find_if(registers, [&](const RegisterInfo& r) { return same_name(r.name, name); });
    return it == registers.end() ? nullptr : &*it;
}

const RegisterInfo* Profile::find(std::uint16_t address) const noexcept {
    const auto it = std::ranges::find(registers, std::optional<std::uint16_t>(address), &RegisterInfo::address);
    return it == registers.end() ? nullptr : &*it;
}

std::expected<const RegisterInfo*, std::string> frequency_reference(const Profile& profile) {
    if (!profile.control || profile.control->reference.empty()) {
        return std::unexpected("the " + profile.type + " profile names no frequency reference register");
    }
    const auto* r = profile.find(profile.control->reference);
    if (r == nullptr || !r->address) {
        return std::unexpected("the " + profile.type + " profile's frequency reference " + profile.control->reference +
                               " has no Modbus address");
    }
    if (r->unit != "Hz") {
        return std::unexpected("the " + profile.type + " profile gives its frequency reference " + r->name +
                               (r->unit.empty() ? " no unit and scale" : " the unit '" + r->unit + "'") +
                               ", not Hz: a frequency cannot be converted (write " + r->name +
                               " as a raw word if its scaling is known)");
    }
    return r;
}

const FaultCode* Profile::fault(std::uint16_t code) const noexcept {
    const auto it = std::ranges::find(fault_codes, code, &FaultCode::code);
    return it == fault_codes.end() ? nullptr : &*it;
}

const IndirectBlock* Profile::block(std::uint8_t function) const noexcept {
    const auto it = std::ranges::find(indirect_blocks, function, &IndirectBlock::function);
    return it == indirect_blocks.end() ? nullptr : &*it;
}

}  // namespace drivebus
