// SPDX-License-Identifier: Apache-2.0
#include "running_bus.hpp"

#include <poll.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdint>

#include "log/log.hpp"
#include "rt/realtime.hpp"
#include "serial/termios.hpp"
#include "serial/tuning.hpp"

namespace drivebus::daemon {
namespace {

// The service thread's priority under the bus thread's (rt::service_priority()); refused, a
// warning: the bus itself runs on.
void service_thread_realtime(const config::RealtimeConfig& rt, const std::string& bus) {
    if (rt.mode == config::RealtimeMode::Off) {
        return;
    }
    const auto priority = rt::service_priority(rt.priority);
    if (!priority) {
        log::info("bus " + bus +
                  ": the ipc thread stays at normal priority, the bus threads' priority 1 has "
                  "nothing under it");
        return;
    }
    if (auto done = rt::make_realtime(*priority, {}); !done) {
        log::warning("bus " + bus + ": ipc thread (control leases and their fallback): " + done.error() +
                     "; running at normal priority");
    }
}

// How long a stopping bus waits for its fallbacks: each drive's every attempt, twice over
// (a reply on its way, a drive found absent), and at most 10 s, well inside systemd's
// TimeoutStopSec.
// Whether `fd` turns readable by `deadline` (poll again after a signal, with what is left).
bool readable_by(int fd, std::chrono::steady_clock::time_point deadline) {
    for (;;) {
        const auto left =
            std::chrono::ceil<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now()).count();
        pollfd p{fd, POLLIN, 0};
        const int n = ::poll(&p, 1, static_cast<int>(std::max<std::int64_t>(left, 0)));
        if (n > 0) {
            return true;
        }
        if (n == 0 || errno != EINTR) {
            return false;
        }
    }
}

std::chrono::steady_clock::duration fallback_wait(const config::BusConfig& bus) {
    const auto attempt = bus.response_timeout + bus.late_reply_guard.value_or(bus.response_timeout);
    const auto times = static_cast<std::int64_t>(2 * (bus.retries + 1) * std::max<std::size_t>(1, bus.drives.size()));
    const std::chrono::steady_clock::duration all = times * attempt + std::chrono::milliseconds(500);
    return std::min<std::chrono::steady_clock::duration>(all, std::chrono::seconds(10));
}

}  // namespace

std::expected<RunningBus, std::string> start_bus(const config::BusConfig& settings, const config::RealtimeConfig& rt,
                                                 const ipc::Layout& layout, const rt::KernelFacts& kernel,
                                                 const ipc::Carried& carried) {
    RunningBus b;
    b.config = std::make_unique<config::BusConfig>(settings);
    const auto& bus = *b.config;
    // What stands on the kernel's side between the wire and the bus's reads: a notice where a
    // setting works against exact framing (docs/rs485.md).
    for (const auto& finding : rt::judge(kernel, rt::read_port_facts(serial::tty_name(bus.device)))) {
        log::write(finding.against_framing ? log::Level::Notice : log::Level::Info,
                   "bus " + bus.name + ": " + finding.text, {.bus = bus.name});
    }
    // The bus thread and the ipc thread meet only in the loop's hand-over rings.
    bus::LoopOptions loop_options;
    loop_options.realtime = rt;
    loop_options.send_spin = rt.send_spin;
    b.loop = std::make_unique<bus::BusLoop>(bus, master::EngineCallbacks{}, std::move(loop_options));
    b.service = std::make_unique<ipc::BusService>(bus, layout, *b.loop, carried);
    if (auto started = b.loop->start(); !started) {
        return std::unexpected(started.error() + "; [realtime] mode is required");
    }
    log::notice("bus " + bus.name + ": " + bus.device.string() + ", " + serial::describe(bus.format) + ", " +
                    std::to_string(bus.drives.size()) + " drives",
                {.bus = bus.name});
    b.service->start([rt, name = bus.name] { service_thread_realtime(rt, name); });
    return b;
}

// The bus thread first, so that every request it had is answered (the one on the wire as the
// line going down does), then the ipc thread, which answers them and the rest, and gives up
// the leases held now and the snapshots' sequences.
ipc::Carried restart_bus(RunningBus& b) {
    b.loop->stop();
    auto carried = b.service->retire();
    b.service.reset();
    b.loop.reset();
    return carried;
}

void end_buses(std::vector<RunningBus>& buses) {
    std::vector<int> wound;
    for (auto& b : buses) {
        wound.push_back(b.service->wind_down());
    }
    const auto start = std::chrono::steady_clock::now();
    for (std::size_t i = 0; i < buses.size(); ++i) {
        const auto& bus = *buses[i].config;
        if (!readable_by(wound[i], start + fallback_wait(bus))) {
            log::error("bus " + bus.name +
                           ": the fallback writes were not all answered in time; the line is let go, and the "
                           "next drivebusd applies them again",
                       {.bus = bus.name});
        }
        (void)restart_bus(buses[i]);
    }
    buses.clear();
}

}  // namespace drivebus::daemon
