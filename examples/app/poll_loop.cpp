// SPDX-License-Identifier: Apache-2.0
// An application on its own event loop (here plain poll(2); asio, Qt, GLib or asyncio work the
// same way): libdrivebus connected with Delivery::Dispatch starts no thread, the loop watches
// the bus's descriptor beside its own timer, and every callback runs on the loop's thread.
//
//   poll_loop [--bus NAME] [--drive NAME] [--read FD00] [--write FA01] [--value 3000] [--seconds 2]
//
// It follows the drive's snapshots, reads one register every 100 ms, writes another once (which
// takes the drive's control lease), renews the lease on every pass of the loop, and gives it
// back at the end. Last it prints the process's threads: its own and the iceoryx runtime's
// keep-alive, none of the library's.
#include <poll.h>
#include <sys/timerfd.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>

#include "drivebus/client.hpp"

namespace {

struct Args {
    std::string bus;
    std::string drive = "pump";
    std::string read = "FD00";
    std::string write = "FA01";
    std::uint16_t value = 3000;
    double seconds = 2.0;
};

Args parse(int argc, char** argv) {
    Args a;
    for (int i = 1; i + 1 < argc; i += 2) {
        const std::string_view key = argv[i];
        const char* value = argv[i + 1];
        if (key == "--bus") {
            a.bus = value;
        } else if (key == "--drive") {
            a.drive = value;
        } else if (key == "--read") {
            a.read = value;
        } else if (key == "--write") {
            a.write = value;
        } else if (key == "--value") {
            a.value = static_cast<std::uint16_t>(std::atoi(value));
        } else if (key == "--seconds") {
            a.seconds = std::atof(value);
        } else {
            std::fprintf(stderr, "poll_loop: unknown option %s\n", argv[i]);
            std::exit(2);
        }
    }
    return a;
}

int fail(const drivebus::Error& e) {
    std::fprintf(stderr, "poll_loop: %s\n", e.message.c_str());
    return 1;
}

// The names of this process's threads, as /proc lists them.
std::string threads() {
    std::string names;
    int count = 0;
    for (const auto& task : std::filesystem::directory_iterator("/proc/self/task")) {
        std::ifstream comm(task.path() / "comm");
        std::string name;
        std::getline(comm, name);
        names += (names.empty() ? "" : ",") + name;
        ++count;
    }
    return std::to_string(count) + " " + names;
}

}  // namespace

int main(int argc, char** argv) {
    const Args args = parse(argc, argv);
    drivebus::ConnectOptions options;
    options.application = "poll_loop";
    options.delivery = drivebus::Delivery::Dispatch;
    auto bus = drivebus::Bus::connect(args.bus, options);
    if (!bus) {
        return fail(bus.error());
    }
    auto drive = bus->drive(args.drive);
    if (!drive) {
        return fail(drive.error());
    }
    const auto read_at = drive->resolve(args.read);
    const auto write_at = drive->resolve(args.write);
    if (!read_at || !write_at) {
        return fail(!read_at ? read_at.error() : write_at.error());
    }

    // Called in dispatch(), on this thread: nothing here needs a lock.
    std::uint64_t last = 0;
    int snapshots = 0;
    int out_of_order = 0;
    auto subscription = drive->on_snapshot([&](const drivebus::shm::DriveSnapshot& s) {
        out_of_order += s.sequence <= last ? 1 : 0;
        last = s.sequence;
        ++snapshots;
    });

    // The loop's own timer: a pass every 100 ms.
    const int tick = ::timerfd_create(CLOCK_MONOTONIC, TFD_NONBLOCK | TFD_CLOEXEC);
    const itimerspec every{.it_interval = {0, 100'000'000}, .it_value = {0, 100'000'000}};
    if (tick < 0 || ::timerfd_settime(tick, 0, &every, nullptr) != 0) {
        std::perror("poll_loop: timerfd");
        return 1;
    }
    int reads = 0;
    int renewals = 0;
    int failures = 0;
    bool written = false;
    bool released = false;
    bool wrote = false;
    const auto until = drivebus::Clock::now() + std::chrono::duration<double>(args.seconds);
    while (!released) {
        std::array<pollfd, 2> fds{{{bus->descriptor(), POLLIN, 0}, {tick, POLLIN, 0}}};
        if (::poll(fds.data(), fds.size(), -1) < 0) {
            continue;  // EINTR
        }
        if ((fds[0].revents & POLLIN) != 0) {
            bus->dispatch();
        }
        if ((fds[1].revents & POLLIN) == 0) {
            continue;
        }
        std::uint64_t expirations = 0;
        (void)::read(tick, &expirations, sizeof expirations);
        if (drivebus::Clock::now() >= until) {
            if (!wrote) {  // the write's answer is still to come
                continue;
            }
            drive->async_release_control([&](std::expected<void, drivebus::Error> r) {
                std::printf("release %s\n", r ? "ok" : r.error().message.c_str());
                released = true;
            });
            ::close(tick);
            // The release's answer, on the bus's descriptor alone.
            while (!released) {
                pollfd p{bus->descriptor(), POLLIN, 0};
                if (::poll(&p, 1, -1) > 0) {
                    bus->dispatch();
                }
            }
            break;
        }
        drive->async_read(*read_at, 1, [&](std::expected<std::vector<std::uint16_t>, drivebus::Error> r) {
            if (!r) {
                ++failures;
                std::printf("read %s failed: %s\n", args.read.c_str(), r.error().message.c_str());
                return;
            }
            ++reads;
            std::printf("read %s %u\n", args.read.c_str(), static_cast<unsigned>(r->front()));
        });
        if (!written) {
            written = true;
            const std::array value{args.value};
            drive->async_write(*write_at, value, [&](std::expected<void, drivebus::Error> r) {
                wrote = true;
                failures += r ? 0 : 1;
                std::printf("write %s %u %s\n", args.write.c_str(), static_cast<unsigned>(args.value),
                            r ? "ok" : r.error().message.c_str());
            });
        } else if (wrote) {
            // This loop is alive: say so. Only this renews the lease between writes.
            drive->async_keep_alive([&](std::expected<void, drivebus::Error> r) {
                renewals += r ? 1 : 0;
                failures += r ? 0 : 1;
            });
        }
    }
    subscription.reset();
    std::printf("snapshots %d out-of-order %d reads %d renewals %d failures %d\n", snapshots, out_of_order, reads,
                renewals, failures);
    std::printf("threads %s\n", threads().c_str());
    return failures == 0 && out_of_order == 0 && snapshots > 0 ? 0 : 1;
}
