// SPDX-License-Identifier: Apache-2.0
// drivebusctl watch: every drive of the bus, refreshed in place until q, Ctrl-C or SIGTERM.
#include <fmt/format.h>

#include "commands.hpp"
#include "format.hpp"
#include "terminal.hpp"
#include "view.hpp"

namespace drivebus::ctl {
namespace {

constexpr std::string_view kClearScreen = "\x1b[2J";
constexpr std::string_view kHome = "\x1b[H";
constexpr std::string_view kClearLine = "\x1b[K";
constexpr std::string_view kClearBelow = "\x1b[J";

// One screen: each line cleared to its end, and whatever an older, longer screen left below.
std::string screen(const std::vector<std::string>& lines) {
    std::string out(kHome);
    for (const auto& line : lines) {
        out += line;
        out += kClearLine;
        out += "\r\n";
    }
    out += kClearBelow;
    return out;
}

std::string plain(const std::vector<std::string>& lines) {
    std::string out;
    for (const auto& line : lines) {
        out += line + "\n";
    }
    return out + "\n";
}

}  // namespace

int run_watch(const Options& options, std::chrono::milliseconds interval) {
    auto bus = Bus::connect(options.bus, connect_options(options));
    if (!bus) {
        return report(options, bus.error());
    }
    const auto first = bus->status(Milliseconds(1000));
    if (!first) {
        return report(options, first.error());
    }
    std::vector<Drive> drives;
    for (std::size_t i = 0; i < first->drive_count && i < first->drives.size(); ++i) {
        auto d = bus->drive(shm::view(first->drives[i].name));
        if (!d) {
            return report(options, d.error());
        }
        drives.push_back(std::move(*d));
    }

    std::optional<Error> failure;
    {
        Terminal terminal;
        const bool redraw = terminal.output_is_tty() && !options.json;
        if (redraw && !Terminal::write(kClearScreen)) {
            return kExitOk;
        }
        for (;;) {
            const auto status = bus->status();
            if (!status || !bus->daemon_alive()) {
                failure = Error{ErrorKind::DaemonGone,
                                "drivebusd has gone silent (no bus status); watch ended",
                                0,
                                shm::RejectReason::None,
                                {},
                                0};
                break;
            }
            std::vector<WatchDrive> view;
            for (std::size_t i = 0; i < drives.size(); ++i) {
                WatchDrive w;
                w.name = drives[i].name();
                w.address = drives[i].address();
                w.profile = drives[i].profile();
                if (i < status->drives.size()) {
                    w.profile_type = std::string(shm::view(status->drives[i].profile));
                    w.health = status->drives[i].health;
                }
                if (auto s = drives[i].wait_snapshot(Milliseconds(0))) {
                    w.snapshot = *s;
                }
                view.push_back(std::move(w));
            }
            const auto now = monotonic_ns();
            std::string out;
            if (options.json) {
                out = watch_json(*status, view, now).dump() + "\n";
            } else if (redraw) {
                out = screen(watch_lines(*status, view, interval, now));
            } else {
                out = plain(watch_lines(*status, view, interval, now));
            }
            if (!Terminal::write(out)) {
                break;  // stdout closed: nobody is watching
            }
            if (terminal.wait(interval) == Terminal::Event::Quit) {
                break;
            }
        }
        if (redraw) {
            (void)Terminal::write("\r\n");
        }
    }  // the terminal is restored here, before any message
    if (failure) {
        return report(options, *failure);
    }
    return kExitOk;
}

}  // namespace drivebus::ctl
