// SPDX-License-Identifier: Apache-2.0
#include "faults.hpp"

#include "duration/duration.hpp"

#include <charconv>
#include <cmath>
#include <sstream>

namespace drivebus::sim {
namespace {

std::expected<double, std::string> parse_number(std::string_view key, std::string_view text) {
    double value = 0.0;
    const auto* end = text.data() + text.size();
    const auto [ptr, ec] = std::from_chars(text.data(), end, value);
    if (ec != std::errc() || ptr != end || !std::isfinite(value)) {
        return std::unexpected(std::string(key) + ": '" + std::string(text) + "' is not a number");
    }
    return value;
}

std::expected<double, std::string> parse_share(std::string_view key, std::string_view text) {
    auto value = parse_number(key, text);
    if (value && (*value < 0.0 || *value > 1.0)) {
        return std::unexpected(std::string(key) + ": share must be between 0 and 1, got " + std::string(text));
    }
    return value;
}

std::expected<std::size_t, std::string> parse_count(std::string_view key, std::string_view text, std::size_t max) {
    std::size_t value = 0;
    const auto* end = text.data() + text.size();
    const auto [ptr, ec] = std::from_chars(text.data(), end, value);
    if (ec != std::errc() || ptr != end || value > max) {
        return std::unexpected(std::string(key) + ": '" + std::string(text) + "' is not a whole number from 0 to " +
                               std::to_string(max));
    }
    return value;
}

// Splits "a:b" into a and b (b empty when there is no colon).
std::pair<std::string_view, std::string_view> split_colon(std::string_view text) {
    const auto colon = text.find(':');
    if (colon == std::string_view::npos) {
        return {text, {}};
    }
    return {text.substr(0, colon), text.substr(colon + 1)};
}

}  // namespace

std::expected<rtu::Duration, std::string> option_duration(std::string_view text) {
    const auto d = drivebus::parse_duration(text);
    if (!d) {
        return std::unexpected("'" + std::string(text) + "' " + d.error());
    }
    if (*d > std::chrono::hours(1)) {
        return std::unexpected("'" + std::string(text) + "' is above 1 hour");
    }
    return *d;
}

std::expected<void, std::string> FaultTable::apply(rtu::SlaveAddress address, std::string_view assignment) {
    const auto eq = assignment.find('=');
    if (eq == std::string_view::npos) {
        return std::unexpected("'" + std::string(assignment) + "' is not key=value");
    }
    const std::string_view key = assignment.substr(0, eq);
    const std::string_view value = assignment.substr(eq + 1);
    DriveFaults f = for_drive(address);

    if (key == "echo") {
        const auto on = parse_count(key, value, 1);
        if (!on) {
            return std::unexpected(on.error());
        }
        echo_ = *on == 1;
        return {};
    }
    if (key == "crc" || key == "drop") {
        const auto share = parse_share(key, value);
        if (!share) {
            return std::unexpected(share.error());
        }
        (key == "crc" ? f.crc : f.drop) = *share;
    } else if (key == "late") {
        const auto delay = option_duration(value);
        if (!delay) {
            return std::unexpected("late: " + delay.error());
        }
        f.late = *delay;
    } else if (key == "gap") {
        const auto [at, chars] = split_colon(value);
        const auto k = parse_count("gap", at, 255);
        const auto n = parse_number("gap", chars);
        if (!k || !n || chars.empty() || *n < 0.0 || *n > 1000.0) {
            return std::unexpected("gap: expected K:N, a silence of N character times before byte K (K 1-255)");
        }
        f.gap_at = (*n > 0.0 && *k > 0) ? std::optional<std::size_t>(*k) : std::nullopt;
        f.gap_chars = *n;
    } else if (key == "noise") {
        const auto [count, silence] = split_colon(value);
        const auto n = parse_count("noise", count, 255);
        if (!n) {
            return std::unexpected(n.error());
        }
        double gap = 2.0;
        if (!silence.empty()) {
            const auto g = parse_number("noise", silence);
            if (!g || *g < 0.0 || *g > 1000.0) {
                return std::unexpected("noise: expected N[:GAP], GAP the silence after the noise in character times");
            }
            gap = *g;
        }
        f.noise = *n;
        f.noise_gap_chars = gap;
    } else if (key == "exception") {
        if (value == "off" || value == "0") {
            f.exception.reset();
        } else {
            const auto code = parse_count(key, value, 255);
            if (!code || *code == 0) {
                return std::unexpected("exception: expected a code from 1 to 255, or off");
            }
            f.exception = static_cast<std::uint8_t>(*code);
        }
    } else {
        return std::unexpected("unknown fault '" + std::string(key) +
                               "' (known: crc, drop, late, gap, noise, exception, echo)");
    }
    faults_[address] = f;
    return {};
}

void FaultTable::clear(std::optional<rtu::SlaveAddress> address) {
    if (address) {
        faults_.erase(*address);
    } else {
        faults_.clear();
        echo_ = false;
    }
}

const DriveFaults& FaultTable::for_drive(rtu::SlaveAddress address) const noexcept {
    static const DriveFaults kNone{};
    if (const auto it = faults_.find(address); it != faults_.end()) {
        return it->second;
    }
    if (const auto it = faults_.find(0); it != faults_.end()) {
        return it->second;
    }
    return kNone;
}

std::string FaultTable::to_string() const {
    std::ostringstream out;
    out << "echo=" << (echo_ ? 1 : 0);
    for (const auto& [address, f] : faults_) {
        out << (address == 0 ? " *:" : " " + std::to_string(address) + ":") << " crc=" << f.crc << " drop=" << f.drop
            << " late=" << std::chrono::duration<double, std::milli>(f.late).count() << "ms";
        if (f.gap_at) {
            out << " gap=" << *f.gap_at << ':' << f.gap_chars;
        }
        if (f.noise > 0) {
            out << " noise=" << f.noise << ':' << f.noise_gap_chars;
        }
        if (f.exception) {
            out << " exception=" << static_cast<int>(*f.exception);
        }
    }
    return out.str();
}

std::string FaultCounters::to_string() const {
    std::ostringstream out;
    out << "requests=" << requests << " broadcasts=" << broadcasts << " replies=" << replies
        << " exceptions=" << exceptions << " foreign=" << foreign << " broken=" << broken << " injected:"
        << " crc=" << crc << " dropped=" << dropped << " late=" << late << " gap=" << gap << " noise=" << noise
        << " echoed_bytes=" << echoed << " exception=" << injected_exceptions;
    return out.str();
}

}  // namespace drivebus::sim
