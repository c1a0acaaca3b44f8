// SPDX-License-Identifier: Apache-2.0
#include "bus/line_check.hpp"

#include <linux/serial.h>
#include <sys/ioctl.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <iomanip>
#include <map>
#include <mutex>
#include <optional>
#include <sstream>
#include <thread>

#include "bus/bus_loop.hpp"
#include "bus/line_opener.hpp"
#include "drivebus/profile.hpp"
#include "serial/gpio_line.hpp"
#include "serial/termios.hpp"

namespace drivebus::bus {
namespace {

using namespace std::chrono_literals;

constexpr int kOk = 0;
constexpr int kFailed = 1;
constexpr int kConfig = 78;

// The worse of two exit codes: a configuration error, then a failure, then success.
int worse(int a, int b) {
    const auto rank = [](int code) {
        if (code == kConfig) {
            return 2;
        }
        return code == kOk ? 0 : 1;
    };
    return rank(a) >= rank(b) ? a : b;
}

std::string hex(std::uint32_t value, int digits) {
    std::ostringstream text;
    text << "0x" << std::hex << std::setw(digits) << std::setfill('0') << value;
    return text.str();
}

std::string rs485_text(const serial_rs485& conf) {
    std::string names;
    const auto flag = [&](std::uint32_t bit, const char* name) {
        if ((conf.flags & bit) != 0) {
            names += (names.empty() ? "" : ", ") + std::string(name);
        }
    };
    flag(SER_RS485_ENABLED, "enabled");
    flag(SER_RS485_RTS_ON_SEND, "rts_on_send");
    flag(SER_RS485_RTS_AFTER_SEND, "rts_after_send");
    flag(SER_RS485_RX_DURING_TX, "rx_during_tx");
    return "flags " + hex(conf.flags, 1) + (names.empty() ? "" : " (" + names + ")") + ", delay before send " +
           std::to_string(conf.delay_rts_before_send) + " ms, after send " + std::to_string(conf.delay_rts_after_send) +
           " ms";
}

std::optional<serial_rs485> read_rs485(int fd) {
    serial_rs485 conf{};
    if (::ioctl(fd, TIOCGRS485, &conf) != 0) {
        return std::nullopt;
    }
    return conf;
}

// The register a line check reads: the profile's status word, else its first monitoring
// register, else its first readable one.
const RegisterInfo* check_register(const Profile& profile) {
    if (profile.control) {
        if (const auto* status = profile.find(profile.control->status); status != nullptr && status->address) {
            return status;
        }
    }
    const auto readable_in = [&](std::string_view group) {
        const auto it = std::ranges::find_if(profile.registers, [&](const RegisterInfo& r) {
            return r.address.has_value() && readable(r.access) && (group.empty() || r.group == group);
        });
        return it == profile.registers.end() ? nullptr : &*it;
    };
    const auto* monitoring = readable_in("monitoring");
    return monitoring != nullptr ? monitoring : readable_in("");
}

std::string milliseconds(rtu::Duration d) {
    std::ostringstream text;
    text << std::fixed << std::setprecision(1) << std::chrono::duration<double, std::milli>(d).count() << " ms";
    return text.str();
}

// The port and its driver-enable control, made once and released. kOk when both are usable.
int check_port(const config::BusConfig& bus, std::ostream& out) {
    auto port = serial::Port::open(serial::PortOptions{bus.device, bus.format, bus.lock_dir});
    if (!port) {
        out << "  port: " << port.error().message;
        if (!port.error().device_gone()) {
            out << "; the line check needs the line to itself (is drivebusd running? systemctl stop drivebusd)";
        }
        out << '\n';
        return kFailed;
    }
    out << "  port: open, exclusive\n";
    for (const auto& note : port->tuning()) {
        out << "  tuning: " << note << '\n';
    }
    const auto uart = serial::kernel_uart_control();
    const auto empty = uart->transmitter_empty(port->fd());
    out << "  transmitter empty (TIOCSERGETLSR): "
        << (empty ? "reported by the driver: the end of each request is seen, not computed"
                  : "not reported by the driver: the end of each request is computed from the baud rate")
        << '\n';
    const bool kernel = bus.direction == config::DirectionMode::Kernel;
    if (kernel) {
        if (const auto found = read_rs485(port->fd())) {
            out << "  RS485 as found: " << rs485_text(*found) << '\n';
        }
    }
    auto direction = make_direction(bus, port->fd(), *uart);
    if (!direction) {
        out << "  driver enable: " << refusal(bus, direction.error()) << '\n';
        return direction.error().permanent ? kConfig : kFailed;
    }
    const auto method = (*direction)->name();
    if (kernel && method == "kernel") {
        const auto kept = read_rs485(port->fd());
        out << "  RS485 as asked, and kept by the driver: " << (kept ? rs485_text(*kept) : "unreadable") << '\n';
    } else if (kernel) {
        out << "  driver enable: the driver has no RS485 support; kernel_fallback = \"" << method << "\"\n";
    } else if (method == "gpio" && bus.gpio) {
        out << "  driver enable: " << serial::describe(*bus.gpio) << ", requested: an output of consumer drivebusd, "
            << (bus.gpio->active_low ? "active low" : "active high") << ", at its inactive level\n";
    } else if (method == "rts") {
        out << "  driver enable: RTS, set by drivebusd around each request\n";
    } else {
        out << "  driver enable: none (the adapter switches by itself)\n";
    }
    return kOk;
}

// One read of each drive through the bus thread and its master, as drivebusd sends them.
int check_drives(const config::BusConfig& configured, std::ostream& out) {
    // Read-only: no polls, keep-alives or set-up writes (comm_timeout, write_block).
    config::BusConfig bus = configured;
    for (auto& drive : bus.drives) {
        drive.polls.clear();
        drive.keep_alive.reset();
        drive.comm_timeout.reset();
        drive.write_block.clear();
    }
    std::mutex mutex;
    std::condition_variable answered;
    std::map<std::uint64_t, master::Result> results;
    master::EngineCallbacks callbacks;
    callbacks.client_result = [&](std::uint64_t id, const master::Result& result) {
        const std::lock_guard lock(mutex);
        results[id] = result;
        answered.notify_all();
    };
    BusLoop loop(bus, callbacks);
    if (auto started = loop.start(); !started) {
        out << "  bus thread: " << started.error() << '\n';
        return kFailed;
    }
    // The bus takes requests once its line is open (it was, a moment ago, in check_port()).
    const auto open_by = std::chrono::steady_clock::now() + 10s;
    while (!loop.up() && std::chrono::steady_clock::now() < open_by) {
        std::this_thread::sleep_for(10ms);
    }
    if (!loop.up()) {
        out << "  bus thread: the line did not open within 10 s\n";
        loop.stop();
        return kFailed;
    }
    // Every attempt's time-out, and the wire and the drive's own set-up reads besides.
    const auto limit = (bus.response_timeout + 1s) * (bus.retries + 1) + 10s;
    int code = kOk;
    std::size_t ok = 0;
    for (std::uint64_t i = 0; i < bus.drives.size(); ++i) {
        const auto& drive = bus.drives[i];
        out << "  drive " << drive.name << " (address " << int{drive.address} << ", " << drive.profile->type << "): ";
        const auto* reg = check_register(*drive.profile);
        if (reg == nullptr) {
            out << "its profile has no readable register\n";
            code = worse(code, kFailed);
            continue;
        }
        const rtu::RequestAdu request{drive.address, rtu::ReadHoldingRegisters{*reg->address, 1}};
        if (auto submitted = loop.submit({.client = 1, .correlation = i, .request = request}); !submitted) {
            out << "the bus thread refused the request\n";
            code = worse(code, kFailed);
            continue;
        }
        // The result comes through the callback; a request the bus did not take (the line went
        // down) only through the hand-over ring, which this thread alone reads.
        std::optional<master::Refusal> refusal;
        const auto deadline = std::chrono::steady_clock::now() + limit;
        std::unique_lock lock(mutex);
        while (!results.contains(i) && !refusal && std::chrono::steady_clock::now() < deadline) {
            answered.wait_for(lock, 50ms, [&] { return results.contains(i); });
            master::Finished f;
            while (loop.handover().results.try_pop(f)) {
                if (f.id == i && f.refusal != master::Refusal::None && f.refusal != master::Refusal::NotWithdrawn) {
                    refusal = f.refusal;
                }
            }
        }
        if (!results.contains(i)) {
            out << reg->name << ": "
                << (refusal
                        ? std::string(*refusal == master::Refusal::BusDown ? "not sent: the line went down"
                                                                           : "not sent: refused by the bus")
                        : "no result within " +
                              std::to_string(std::chrono::duration_cast<std::chrono::seconds>(limit).count()) + " s")
                << '\n';
            code = worse(code, kFailed);
            continue;
        }
        const auto& result = results.at(i);
        const auto attempts = std::to_string(result.attempts) + (result.attempts == 1 ? " attempt" : " attempts");
        if (result.outcome == master::Outcome::Ok) {
            const auto values = std::get<rtu::ReadHoldingRegistersResponse>(*result.response).values.words();
            const std::uint16_t value = values.empty() ? 0 : values[0];
            out << reg->name << " = " << hex(value, 4) << " (" << value << "), the reply in "
                << milliseconds(result.latency) << ", " << attempts << '\n';
            ++ok;
        } else if (const auto exception = result.exception()) {
            out << reg->name << ": exception " << int{static_cast<std::uint8_t>(*exception)} << " ("
                << rtu::to_string(*exception) << "): the drive answers, but not this read\n";
            ++ok;  // the line works: the drive answered
        } else {
            out << reg->name << ": " << master::to_string(result.outcome) << " after " << attempts << '\n';
            code = worse(code, kFailed);
        }
    }
    // The last request drivebusd sent of its own (a drive's set-up read) may still be out: its
    // answer, or its time-out, before the counters are read.
    const auto settled = [](const master::BusCounters& k) {
        return k.transmissions <=
               k.replies + k.timeouts + k.crc_errors + k.gap_errors + k.parity_errors + k.malformed + k.echo_mismatches;
    };
    const auto settle_by = std::chrono::steady_clock::now() + bus.response_timeout + 1s;
    while (!settled(loop.status().counters) && std::chrono::steady_clock::now() < settle_by) {
        std::this_thread::sleep_for(10ms);
    }
    const auto c = loop.status().counters;
    loop.stop();
    out << "  line (drivebusd's own reads of a drive coming online included): " << c.transmissions << " requests, "
        << c.replies << " replies, " << c.timeouts << " time-outs, " << c.crc_errors << " CRC errors, "
        << c.parity_errors << " parity errors, " << c.gap_errors << " gaps in a frame, " << c.noise << " noise, "
        << c.foreign << " foreign frames, " << c.late_replies << " late replies\n";
    out << "  " << ok << " of " << bus.drives.size() << " drives answered\n";
    return code;
}

}  // namespace

int check_lines(const config::Config& config, const LineCheckOptions& options, std::ostream& out) {
    out << std::unitbuf;  // each line as it is known: a drive that does not answer takes seconds
    int code = kOk;
    bool found = false;
    for (const auto& bus : config.buses) {
        if (!options.bus.empty() && bus.name != options.bus) {
            continue;
        }
        found = true;
        out << "bus " << bus.name << ": " << bus.device.string() << ", " << serial::describe(bus.format)
            << ", direction " << config::to_string(bus.direction) << '\n';
        int bus_code = check_port(bus, out);
        if (bus_code == kOk) {
            bus_code = check_drives(bus, out);
        }
        out << "bus " << bus.name << ": " << (bus_code == kOk ? "ok" : "FAILED") << "\n";
        code = worse(code, bus_code);
    }
    if (!found) {
        std::string names;
        for (const auto& bus : config.buses) {
            names += (names.empty() ? "" : ", ") + bus.name;
        }
        out << "no bus '" << options.bus << "' in the configuration (there are " << names << ")\n";
        return kConfig;
    }
    return code;
}

}  // namespace drivebus::bus
