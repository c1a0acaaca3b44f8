// SPDX-License-Identifier: Apache-2.0
#include "commands.hpp"

#include <charconv>
#include <sstream>
#include <vector>

namespace drivebus::sim {
namespace {

constexpr std::string_view kHelp =
    "ok commands: drives | idle | stats | silences | faults | fault ADDR|* key=value... | clear [ADDR|*] | "
    "writes ADDR | requests ADDR | mute | unmute | get ADDR REG | set ADDR REG VALUE | option ADDR key=value | power "
    "ADDR";

std::vector<std::string_view> words(std::string_view line) {
    std::vector<std::string_view> out;
    std::size_t i = 0;
    while (i < line.size()) {
        while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) {
            ++i;
        }
        const std::size_t start = i;
        while (i < line.size() && line[i] != ' ' && line[i] != '\t') {
            ++i;
        }
        if (i > start) {
            out.push_back(line.substr(start, i - start));
        }
    }
    return out;
}

template <typename T>
std::optional<T> number(std::string_view text, int base = 10) {
    T value{};
    const auto* end = text.data() + text.size();
    const auto [ptr, ec] = std::from_chars(text.data(), end, value, base);
    if (ec != std::errc() || ptr != end) {
        return std::nullopt;
    }
    return value;
}

// A register value: decimal, or hex with 0x.
std::optional<std::uint16_t> word_value(std::string_view text) {
    if (text.starts_with("0x") || text.starts_with("0X")) {
        return number<std::uint16_t>(text.substr(2), 16);
    }
    return number<std::uint16_t>(text);
}

// "*" is every drive (the line-wide default, address 0).
std::expected<rtu::SlaveAddress, std::string> target(Bus& bus, std::string_view text, bool allow_all) {
    if (allow_all && text == "*") {
        return rtu::SlaveAddress{0};
    }
    const auto address = number<unsigned>(text);
    if (!address || *address < 1 || *address > 247) {
        return std::unexpected("'" + std::string(text) + "' is not a slave address (1-247)" +
                               (allow_all ? " or *" : ""));
    }
    if (bus.drive(static_cast<rtu::SlaveAddress>(*address)) == nullptr) {
        return std::unexpected("no simulated drive at address " + std::to_string(*address));
    }
    return static_cast<rtu::SlaveAddress>(*address);
}

std::string error(const std::string& message) {
    return "error: " + message;
}

}  // namespace

std::string run_command(Bus& bus, std::string_view line, rtu::Instant now, bool line_idle) {
    const auto w = words(line);
    if (w.empty() || w[0] == "help") {
        return std::string(kHelp);
    }
    const std::string_view verb = w[0];
    if (verb == "idle" && w.size() == 1) {
        return line_idle ? "ok idle" : "ok busy";
    }
    if (verb == "stats" && w.size() == 1) {
        return "ok " + bus.counters().to_string();
    }
    if (verb == "silences" && w.size() == 1) {
        return "ok " + bus.silence_summary();
    }
    if (verb == "faults" && w.size() == 1) {
        return "ok " + bus.faults().to_string();
    }
    if (verb == "drives" && w.size() == 1) {
        std::string out = "ok";
        for (const auto address : bus.addresses()) {
            out += " " + std::to_string(address) + ":" + bus.drive(address)->profile().type;
        }
        return out;
    }
    if (verb == "fault" && w.size() >= 3) {
        const auto address = target(bus, w[1], true);
        if (!address) {
            return error(address.error());
        }
        // All or nothing: apply to a copy first.
        FaultTable trial = bus.faults();
        for (std::size_t i = 2; i < w.size(); ++i) {
            if (auto ok = trial.apply(*address, w[i]); !ok) {
                return error(ok.error());
            }
        }
        bus.faults() = trial;
        return "ok " + bus.faults().to_string();
    }
    if (verb == "clear" && w.size() <= 2) {
        if (w.size() == 1 || w[1] == "*") {
            bus.faults().clear(std::nullopt);
        } else {
            const auto address = target(bus, w[1], false);
            if (!address) {
                return error(address.error());
            }
            bus.faults().clear(*address);
        }
        return "ok " + bus.faults().to_string();
    }
    if (verb == "writes" && w.size() == 2) {
        const auto address = target(bus, w[1], false);
        if (!address) {
            return error(address.error());
        }
        std::string out = "ok";
        char item[24];
        for (const auto& [reg, value] : bus.drive(*address)->write_log()) {
            std::snprintf(item, sizeof item, " 0x%04X=%u", reg, value);
            out += item;
        }
        return out;
    }
    if (verb == "mute" && w.size() == 1) {
        bus.set_muted(true);
        return "ok";
    }
    if (verb == "unmute" && w.size() == 1) {
        bus.set_muted(false);
        return "ok";
    }
    if (verb == "requests" && w.size() == 2) {
        const auto address = target(bus, w[1], false);
        if (!address) {
            return error(address.error());
        }
        const auto* drive = bus.drive(*address);
        std::string out = "ok total=" + std::to_string(drive->requests_received());
        char item[32];
        for (const auto& r : drive->request_log()) {
            if (r.value) {
                std::snprintf(item, sizeof item, " %02u:0x%04X=%u", r.function, r.start, *r.value);
            } else {
                std::snprintf(item, sizeof item, " %02u:0x%04X", r.function, r.start);
            }
            out += item;
        }
        return out;
    }
    if (verb == "get" && w.size() == 3) {
        const auto address = target(bus, w[1], false);
        if (!address) {
            return error(address.error());
        }
        bus.advance(now);
        const auto value = bus.drive(*address)->peek(w[2]);
        return value ? "ok " + std::to_string(*value) : error(value.error());
    }
    if (verb == "set" && w.size() == 4) {
        const auto address = target(bus, w[1], false);
        if (!address) {
            return error(address.error());
        }
        const auto value = word_value(w[3]);
        if (!value) {
            return error("'" + std::string(w[3]) + "' is not a 16-bit value (0-65535 or 0x0000-0xFFFF)");
        }
        bus.advance(now);
        const auto ok = bus.drive(*address)->poke(w[2], *value);
        return ok ? "ok" : error(ok.error());
    }
    if (verb == "power" && w.size() == 2) {
        const auto address = target(bus, w[1], false);
        if (!address) {
            return error(address.error());
        }
        bus.advance(now);
        bus.drive(*address)->power_cycle(now);
        return "ok";
    }
    if (verb == "option" && w.size() == 3) {
        auto ok = apply_option_argument(bus, std::string(w[1]) + ":" + std::string(w[2]));
        return ok ? "ok" : error(ok.error());
    }
    return error("cannot parse '" + std::string(line) + "'; try help");
}

std::expected<void, std::string> apply_fault_argument(Bus& bus, std::string_view argument) {
    const auto eq = argument.find('=');
    const auto colon = argument.find(':');
    rtu::SlaveAddress address = 0;
    std::string_view assignment = argument;
    if (colon != std::string_view::npos && (eq == std::string_view::npos || colon < eq)) {
        const auto t = target(bus, argument.substr(0, colon), true);
        if (!t) {
            return std::unexpected("--fault " + std::string(argument) + ": " + t.error());
        }
        address = *t;
        assignment = argument.substr(colon + 1);
    }
    if (auto ok = bus.faults().apply(address, assignment); !ok) {
        return std::unexpected("--fault " + std::string(argument) + ": " + ok.error());
    }
    return {};
}

std::expected<void, std::string> apply_option_argument(Bus& bus, std::string_view argument) {
    const auto colon = argument.find(':');
    const auto eq = argument.find('=');
    if (colon == std::string_view::npos || eq == std::string_view::npos || eq < colon) {
        return std::unexpected("'" + std::string(argument) + "' is not ADDR:key=value");
    }
    const auto address = target(bus, argument.substr(0, colon), false);
    if (!address) {
        return std::unexpected(address.error());
    }
    const std::string_view key = argument.substr(colon + 1, eq - colon - 1);
    double value = 0.0;
    const std::string_view text = argument.substr(eq + 1);
    const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
    if (ec != std::errc() || ptr != text.data() + text.size()) {
        return std::unexpected("option " + std::string(key) + ": '" + std::string(text) + "' is not a number");
    }
    if (!bus.drive(*address)->set_option(key, value)) {
        return std::unexpected("drive " + std::to_string(*address) + " (" + bus.drive(*address)->profile().type +
                               ") has no option '" + std::string(key) + "'");
    }
    return {};
}

std::expected<void, std::string> apply_set_argument(Bus& bus, std::string_view argument) {
    const auto colon = argument.find(':');
    const auto eq = argument.find('=');
    if (colon == std::string_view::npos || eq == std::string_view::npos || eq < colon) {
        return std::unexpected("'" + std::string(argument) + "' is not ADDR:REG=VALUE");
    }
    const auto address = target(bus, argument.substr(0, colon), false);
    if (!address) {
        return std::unexpected(address.error());
    }
    const std::string_view text = argument.substr(eq + 1);
    const auto value = word_value(text);
    if (!value) {
        return std::unexpected("'" + std::string(text) + "' is not a 16-bit value (0-65535 or 0x0000-0xFFFF)");
    }
    return bus.drive(*address)->poke(argument.substr(colon + 1, eq - colon - 1), *value);
}

}  // namespace drivebus::sim
