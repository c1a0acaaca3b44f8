// SPDX-License-Identifier: Apache-2.0
// drivebus-sim's start-up: the drives of --drive and the line of --link or --device.
#include "setup.hpp"

#include <fcntl.h>
#include <sys/inotify.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <map>
#include <memory>

#include "drivebus/profile.hpp"
#include "serial/termios.hpp"

namespace drivebus::sim {

namespace fs = std::filesystem;

[[noreturn]] void fail(int code, const std::string& message) {
    std::cerr << "drivebus-sim: " << message << '\n';
    std::exit(code);
}

namespace {

std::shared_ptr<const Profile> profile_for(const Options& o, const std::string& type,
                                           std::map<std::string, std::shared_ptr<const Profile>>& cache) {
    if (const auto it = cache.find(type); it != cache.end()) {
        return it->second;
    }
    auto loaded =
        o.profile_dir.empty() ? load_profile_by_type(type) : load_profile(fs::path(o.profile_dir) / (type + ".toml"));
    if (!loaded) {
        fail(kExitUsage, "--drive ...:" + type + ": " + loaded.error().message);
    }
    auto profile = std::make_shared<const Profile>(std::move(*loaded));
    cache[type] = profile;
    return profile;
}

}  // namespace

rtu::LineFormat line_format(const Options& o) {
    rtu::LineFormat f;
    f.baud = o.baud;
    f.data_bits = static_cast<std::uint8_t>(o.data_bits);
    f.parity = o.parity == "even" ? rtu::Parity::Even : (o.parity == "odd" ? rtu::Parity::Odd : rtu::Parity::None);
    f.stop_bits = static_cast<std::uint8_t>(o.stop_bits);
    return f;
}

void add_drives(const Options& o, Bus& bus, const rtu::LineFormat& format) {
    std::map<std::string, std::shared_ptr<const Profile>> cache;
    for (const std::string& spec : o.drives) {
        const auto colon = spec.find(':');
        unsigned address = 0;
        if (colon == std::string::npos || std::sscanf(spec.substr(0, colon).c_str(), "%u", &address) != 1) {
            fail(kExitUsage, "--drive " + spec + ": expected ADDRESS:TYPE, such as 1:atv21");
        }
        const std::string type = spec.substr(colon + 1);
        auto profile = profile_for(o, type, cache);
        if (address < profile->address_min || address > profile->address_max) {
            fail(kExitUsage, "--drive " + spec + ": an " + profile->title + " takes addresses " +
                                 std::to_string(profile->address_min) + "-" + std::to_string(profile->address_max));
        }
        if (bus.drive(static_cast<rtu::SlaveAddress>(address)) != nullptr) {
            fail(kExitUsage, "--drive " + spec + ": address " + std::to_string(address) + " is taken twice");
        }
        const auto& parities = profile->parities;
        if (!parities.empty() && std::ranges::find(parities, o.parity) == parities.end()) {
            std::cerr << "drivebus-sim: warning: an " << profile->title << " does not offer parity " << o.parity
                      << "; simulating it anyway\n";
        }
        std::unique_ptr<ProfileDrive> drive;
        try {
            drive = make_drive(static_cast<rtu::SlaveAddress>(address), profile);
        } catch (const std::exception& e) {
            fail(kExitUsage, "--drive " + spec + ": " + e.what());
        }
        // An Altivar 21 on this line has been set to its format (F800 baud, F801 parity).
        if (type == "atv21") {
            (void)drive->poke("F800", format.baud == 9600 ? 0 : 1);
            (void)drive->poke("F801", static_cast<std::uint16_t>(format.parity == rtu::Parity::None   ? 0
                                                                 : format.parity == rtu::Parity::Even ? 1
                                                                                                      : 2));
            (void)drive->poke("F802", static_cast<std::uint16_t>(address));
        }
        bus.add(std::move(drive));
    }
}

Line open_line(const Options& o, const rtu::LineFormat& format) {
    Line line;
    if (!o.link.empty()) {
        auto pty = serial::open_pty();
        if (!pty) {
            fail(kExitRuntime, "cannot open a pty: " + pty.error().message());
        }
        line.link = o.link;
        std::error_code ec;
        const auto status = fs::symlink_status(line.link, ec);
        if (fs::exists(status) && !fs::is_symlink(status)) {
            fail(kExitUsage, "--link " + o.link + ": exists and is not a symlink; not replacing it");
        }
        fs::remove(line.link, ec);
        fs::create_symlink(pty->slave_path, line.link, ec);
        if (ec) {
            fail(kExitRuntime, "--link " + o.link + ": " + ec.message());
        }
        (void)serial::configure_line(pty->slave.get(), format, serial::ErrorMarking::Off);
        line.fd.reset(pty->master.release());
        line.description = o.link + " -> " + pty->slave_path.string();
        line.pty = std::move(*pty);
        return line;
    }
    auto fd =
        sys::posix_call("open", [&] { return ::open(o.device.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC); });
    if (!fd) {
        fail(kExitRuntime, "--device " + o.device + ": " + fd.error().message());
    }
    line.fd.reset(*fd);
    if (auto excl = sys::posix_call("TIOCEXCL", [&] { return ::ioctl(line.fd.get(), TIOCEXCL); }); !excl) {
        fail(kExitRuntime, "--device " + o.device + ": cannot take it exclusively: " + excl.error().message());
    }
    if (auto ok = serial::configure_line(line.fd.get(), format, serial::ErrorMarking::Parmrk); !ok) {
        fail(kExitRuntime, "--device " + o.device + ": " + ok.error().message());
    }
    line.description = o.device;
    return line;
}

void remove_link(const Line& line) {
    if (line.link.empty() || !line.pty) {
        return;
    }
    std::error_code ec;
    if (fs::is_symlink(line.link, ec) && fs::read_symlink(line.link, ec) == line.pty->slave_path) {
        fs::remove(line.link, ec);
    }
}

sys::UniqueFd watch_opens(const Line& line) {
    if (!line.pty) {
        return {};
    }
    auto fd = sys::posix_call("inotify_init1", [] { return ::inotify_init1(IN_NONBLOCK | IN_CLOEXEC); });
    if (!fd) {
        return {};
    }
    sys::UniqueFd watch(*fd);
    if (!sys::posix_call("inotify_add_watch",
                         [&] { return ::inotify_add_watch(watch.get(), line.pty->slave_path.c_str(), IN_OPEN); })) {
        return {};
    }
    return watch;
}

bool drain_opens(int fd) {
    alignas(inotify_event) std::array<char, 4096> buffer{};
    bool opened = false;
    for (;;) {
        const auto n = sys::posix_call("read", [&] { return ::read(fd, buffer.data(), buffer.size()); });
        if (!n || *n <= 0) {
            return opened;
        }
        for (std::size_t at = 0; at + sizeof(inotify_event) <= static_cast<std::size_t>(*n);) {
            inotify_event event{};
            std::memcpy(&event, buffer.data() + at, sizeof event);
            opened = opened || (event.mask & IN_OPEN) != 0;
            at += sizeof(inotify_event) + event.len;
        }
    }
}

}  // namespace drivebus::sim
