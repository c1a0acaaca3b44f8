// SPDX-License-Identifier: Apache-2.0
// The client side of the drivebusd benchmarks (bench/suite.cpp starts it): a separate process
// on libdrivebus, as an application would be. Times are CLOCK_MONOTONIC nanoseconds, written
// to stdout when the run is over (nothing is printed while measuring).
//
//   bench_client BUS snapshots DRIVE N       for N new snapshots of DRIVE: "RECV_NS REPLY_NS SEQ PUB_NS",
//                                            RECV_NS read in the on_snapshot callback (right after
//                                            the library took the sample), REPLY_NS the time_ns
//                                            of its newest register (the end of the reply), PUB_NS its published_ns
//   bench_client BUS writes DRIVE REG N PAUSE_US
//                                            N writes of REG (values 1..N): "SENT_NS DONE_NS",
//                                            SENT_NS just before write(); a pause after each
//                                            one, so the bus is idle when the next is made
//   bench_client BUS reads DRIVE REG COUNT N PAUSE_US
//                                            N reads of COUNT registers from REG: "SENT_NS DONE_NS"
//   bench_client BUS watch SECONDS           subscribed to every drive of the bus for SECONDS:
//                                            "SNAPSHOTS" received in all
// Exit status: 0, or 1 with the library's error on stderr.
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "drivebus/client.hpp"

namespace {

std::int64_t now_ns() {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
        .count();
}

int fail(const drivebus::Error& e) {
    std::fprintf(stderr, "bench_client: %s: %s\n", std::string(drivebus::to_string(e.kind)).c_str(), e.message.c_str());
    return 1;
}

int usage() {
    std::fprintf(stderr,
                 "usage: bench_client BUS snapshots DRIVE N | writes DRIVE REG N PAUSE_US | "
                 "reads DRIVE REG COUNT N PAUSE_US | watch SECONDS\n");
    return 2;
}

struct Pair {
    std::int64_t a = 0;
    std::int64_t b = 0;
};

void print_pairs(const std::vector<Pair>& pairs) {
    for (const auto& p : pairs) {
        std::printf("%lld %lld\n", static_cast<long long>(p.a), static_cast<long long>(p.b));
    }
}

}  // namespace

int main(int argc, char** argv) {
    if (argc < 4) {
        return usage();
    }
    const std::string mode = argv[2];
    drivebus::ConnectOptions options;
    options.application = "bench_client_" + mode;
    auto bus = drivebus::Bus::connect(argv[1], options);
    if (!bus) {
        return fail(bus.error());
    }

    if (mode == "snapshots" && argc == 5) {
        auto drive = bus->drive(argv[3]);
        if (!drive) {
            return fail(drive.error());
        }
        const auto wanted = static_cast<std::size_t>(std::atol(argv[4]));
        struct Sample {
            std::int64_t recv = 0, reply = 0;
            std::uint64_t sequence = 0;
            std::int64_t published = 0;
        };
        std::vector<Sample> samples;
        samples.reserve(wanted + 16);
        std::mutex mutex;
        std::atomic<bool> done{false};
        auto subscription = drive->on_snapshot([&](const drivebus::shm::DriveSnapshot& s) {
            const std::int64_t recv = now_ns();
            std::int64_t reply = 0;
            for (std::size_t i = 0; i < s.register_count && i < s.registers.size(); ++i) {
                if (s.registers[i].valid != 0) {
                    reply = std::max(reply, s.registers[i].time_ns);
                }
            }
            const std::lock_guard lock(mutex);
            if (samples.size() < wanted) {
                samples.push_back({recv, reply, s.sequence, s.published_ns});
            } else {
                done = true;
            }
        });
        const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10 + wanted / 50);
        while (!done && std::chrono::steady_clock::now() < deadline) {
            std::this_thread::sleep_for(std::chrono::milliseconds(20));
        }
        subscription.reset();
        const std::lock_guard lock(mutex);
        for (const auto& s : samples) {
            std::printf("%lld %lld %llu %lld\n", static_cast<long long>(s.recv), static_cast<long long>(s.reply),
                        static_cast<unsigned long long>(s.sequence), static_cast<long long>(s.published));
        }
        return samples.size() >= wanted ? 0 : 1;
    }

    if (mode == "writes" && argc == 7) {
        auto drive = bus->drive(argv[3]);
        if (!drive) {
            return fail(drive.error());
        }
        const auto address = drive->resolve(argv[4]);
        if (!address) {
            return fail(address.error());
        }
        const int n = std::atoi(argv[5]);
        const auto pause = std::chrono::microseconds(std::atol(argv[6]));
        std::vector<Pair> times;
        times.reserve(static_cast<std::size_t>(n));
        for (int i = 1; i <= n; ++i) {
            const auto value = static_cast<std::uint16_t>(i);
            const std::int64_t sent = now_ns();
            if (auto ok = drive->write(*address, std::span(&value, 1)); !ok) {
                return fail(ok.error());
            }
            times.push_back({sent, now_ns()});
            std::this_thread::sleep_for(pause);
        }
        (void)drive->release_control();
        print_pairs(times);
        return 0;
    }

    if (mode == "reads" && argc == 8) {
        auto drive = bus->drive(argv[3]);
        if (!drive) {
            return fail(drive.error());
        }
        const auto address = drive->resolve(argv[4]);
        if (!address) {
            return fail(address.error());
        }
        const auto count = static_cast<std::uint16_t>(std::atoi(argv[5]));
        const int n = std::atoi(argv[6]);
        const auto pause = std::chrono::microseconds(std::atol(argv[7]));
        std::vector<Pair> times;
        times.reserve(static_cast<std::size_t>(n));
        for (int i = 0; i < n; ++i) {
            const std::int64_t sent = now_ns();
            if (auto v = drive->read(*address, count); !v) {
                return fail(v.error());
            }
            times.push_back({sent, now_ns()});
            std::this_thread::sleep_for(pause);
        }
        print_pairs(times);
        return 0;
    }

    if (mode == "watch" && argc == 4) {
        auto status = bus->status(std::chrono::milliseconds(2000));
        if (!status) {
            return fail(status.error());
        }
        std::atomic<std::uint64_t> received{0};
        std::vector<drivebus::Subscription> subscriptions;
        for (std::size_t i = 0; i < status->drive_count && i < status->drives.size(); ++i) {
            auto drive = bus->drive(drivebus::shm::view(status->drives[i].name));
            if (!drive) {
                return fail(drive.error());
            }
            subscriptions.push_back(drive->on_snapshot([&](const drivebus::shm::DriveSnapshot&) { ++received; }));
        }
        std::this_thread::sleep_for(std::chrono::duration<double>(std::atof(argv[3])));
        subscriptions.clear();
        std::printf("%llu\n", static_cast<unsigned long long>(received.load()));
        return 0;
    }
    return usage();
}
