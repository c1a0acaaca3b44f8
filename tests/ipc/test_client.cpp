// SPDX-License-Identifier: Apache-2.0
// A client process for the multi-process tests, driven by its arguments:
//
//   test_client BUS snapshots N           print "snapshot SEQ FD00" for N new pump snapshots
//   test_client BUS unsubscribe           resets a snapshot subscription while its callback is
//                                         under way: "reset waited for the callback", or exit 1
//   test_client BUS read REG N            N reads of REG on the pump: "value V" each (a read whose
//                                         reply failed on the line is asked again, see below)
//   test_client BUS writes REG V...       one write per value, in order, each acknowledged: "ok V"
//   test_client BUS broadcast ADDR V...   one broadcast write (FC06 or FC16) to address 0: "sent"
//   test_client BUS take HZ               a controller's start (FA01 = HZ, FA00 = run), retried on
//                                         QueueFull: "took tries T ms M", then releases the lease
//   test_client BUS flood REG             reads REG until killed: "ready" after the first
//   test_client BUS command HZ            take the pump's lease, run forward at HZ, "holding",
//                                         "client ID" (its Bus::client_id()), then a control loop
//                                         until killed: each new snapshot, keep_alive()
//   test_client BUS hang HZ               same, the loop on its own thread; once FD00 passes 5 Hz
//                                         that thread blocks for good after printing
//                                         "hung T" (T: CLOCK_MONOTONIC ns just before its last
//                                         keep_alive), while the main thread and iceoryx's stay
//                                         alive: the main thread watches the snapshots and prints
//                                         "expired E fallback_ok 0|1" (E: the lease's expired_ns)
//   test_client BUS impostor ID           waits for a pump snapshot whose lease is held, then poses
//                                         as its holder: client id ID, the holder's published name
//                                         and pid, and a token of nothing or made of ID; tries to
//                                         write FA00 = 0xC800, renew and release: "write|renew|
//                                         release STATUS" for each token; exits 0 when every one
//                                         was "not permitted"
//   test_client BUS churn N FIRST         N reads of FE35 or writes of FA51 (FIRST, FIRST+1, ...) at
//                                         random, on through errors (the process soak)
//   test_client BUS lease                 waits (5 s at most) for a pump snapshot whose lease
//                                         expired and whose fallback was acknowledged:
//                                         "lease expired holder kept|none fallback_ok 0|1 registers N"
//   test_client BUS frequency DRIVE HZ    Altivar::set_frequency(HZ) on DRIVE, then gives the lease
//                                         back (release_control): "set"
// Exit status: 0, or 1 with the library's one-line error on stderr.
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <expected>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "drivebus/altivar.hpp"
#include "drivebus/client.hpp"

namespace {

int fail(const drivebus::Error& e) {
    std::fprintf(stderr, "test_client: %s: %s\n", std::string(drivebus::to_string(e.kind)).c_str(), e.message.c_str());
    return 1;
}

// A read, asked again (up to 5 times, each "retry KIND" on stdout) when the line's reply failed:
// on a machine loaded by the rest of the suite a reply can be spoiled or late, which is not
// what these tests are about. Anything else ends the client.
std::expected<std::vector<std::uint16_t>, drivebus::Error> read_on_a_busy_machine(const drivebus::Drive& drive,
                                                                                  const char* reg) {
    for (int attempt = 0;; ++attempt) {
        auto v = drive.read(reg);
        const bool line =
            !v && (v.error().kind == drivebus::ErrorKind::Timeout || v.error().kind == drivebus::ErrorKind::BadFrame ||
                   v.error().kind == drivebus::ErrorKind::LateReply);
        if (!line || attempt == 4) {
            return v;
        }
        std::printf("retry %s\n", std::string(drivebus::to_string(v.error().kind)).c_str());
    }
}

std::int64_t monotonic_ns() {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
        .count();
}

// An application's control loop: on each new snapshot it shows it is alive. With `hang_above`,
// it hangs (blocks on a condition that never comes) once FD00 passes that value.
void control_loop(const drivebus::Drive& pump, std::optional<unsigned> hang_above) {
    std::uint64_t seen = 0;
    for (;;) {
        auto s = pump.wait_snapshot(std::chrono::milliseconds(50), seen);
        if (s) {
            seen = s->sequence;
        }
        const auto before = monotonic_ns();
        if (auto ok = pump.keep_alive(); !ok) {
            std::fprintf(stderr, "keep_alive: %s\n", ok.error().message.c_str());
        }
        const auto* fd00 = s ? s->find(0xFD00) : nullptr;
        if (hang_above && fd00 != nullptr && fd00->value > *hang_above) {
            std::printf("hung %lld\n", static_cast<long long>(before));
            std::mutex m;
            std::condition_variable never;
            std::unique_lock lock(m);
            never.wait(lock, [] { return false; });
        }
    }
}

}  // namespace

int main(int argc, char** argv) {
    if (argc < 3) {
        std::fprintf(stderr, "usage: test_client BUS MODE ARGS...\n");
        return 2;
    }
    const std::string mode = argv[2];
    drivebus::ConnectOptions options;
    options.application = "test_client_" + mode;
    // DRIVEBUS_TEST_DELIVERY=dispatch: the blocking calls on a Bus run by dispatch() (modes
    // snapshots, read, writes).
    // NOLINTNEXTLINE(concurrency-mt-unsafe): read before any thread
    if (const char* delivery = std::getenv("DRIVEBUS_TEST_DELIVERY");
        delivery != nullptr && std::string_view(delivery) == "dispatch") {
        options.delivery = drivebus::Delivery::Dispatch;
    }
    auto bus = drivebus::Bus::connect(argv[1], options);
    if (!bus) {
        return fail(bus.error());
    }
    auto pump = bus->drive("pump");
    if (!pump) {
        return fail(pump.error());
    }
    std::setvbuf(stdout, nullptr, _IOLBF, 0);
    if (mode == "snapshots" && argc == 4) {
        std::uint64_t seen = 0;
        for (int i = 0; i < std::atoi(argv[3]); ++i) {
            auto s = pump->wait_snapshot(std::chrono::seconds(1), seen);
            if (!s && s.error().kind == drivebus::ErrorKind::NoReply) {
                --i;  // nothing new yet: wait on, until the library says the daemon is gone
                continue;
            }
            if (!s) {
                return fail(s.error());
            }
            seen = s->sequence;
            const auto* fd00 = s->find(0xFD00);
            std::printf("snapshot %llu %u\n", static_cast<unsigned long long>(seen), fd00 ? fd00->value : 0U);
        }
        return 0;
    }
    // A snapshot callback that stays under way for 300 ms; the main thread resets its
    // subscription meanwhile and says whether reset() returned before the callback did.
    if (mode == "unsubscribe" && argc == 3) {
        std::atomic<bool> entered{false};
        std::atomic<bool> returned{false};
        auto sub = pump->on_snapshot([&](const drivebus::shm::DriveSnapshot&) {
            if (entered.exchange(true)) {
                return;
            }
            std::this_thread::sleep_for(std::chrono::milliseconds(300));  // a callback at work
            returned = true;
        });
        const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(10);
        while (!entered && std::chrono::steady_clock::now() < until) {
            std::this_thread::sleep_for(std::chrono::milliseconds(1));
        }
        if (!entered) {
            std::printf("no snapshot\n");
            return 1;
        }
        sub.reset();
        std::printf(returned ? "reset waited for the callback\n" : "reset returned during the callback\n");
        return returned ? 0 : 1;
    }
    // Every new snapshot of the pump, for ever: "snapshot SEQUENCE FD00 FD00_READ_NS".
    if (mode == "watch" && argc == 3) {
        std::uint64_t seen = 0;
        for (;;) {
            auto s = pump->wait_snapshot(std::chrono::seconds(1), seen);
            if (!s && s.error().kind == drivebus::ErrorKind::NoReply) {
                continue;
            }
            if (!s) {
                return fail(s.error());
            }
            seen = s->sequence;
            const auto* fd00 = s->find(0xFD00);
            std::printf("snapshot %llu %u %lld\n", static_cast<unsigned long long>(seen), fd00 ? fd00->value : 0U,
                        static_cast<long long>(fd00 ? fd00->time_ns : 0));
        }
    }
    if (mode == "read" && argc == 5) {
        for (int i = 0; i < std::atoi(argv[4]); ++i) {
            auto v = read_on_a_busy_machine(*pump, argv[3]);
            if (!v) {
                return fail(v.error());
            }
            std::printf("value %u\n", v->at(0));
        }
        return 0;
    }
    if (mode == "writes" && argc >= 5) {
        for (int i = 4; i < argc; ++i) {
            const auto value = static_cast<std::uint16_t>(std::strtoul(argv[i], nullptr, 0));
            if (auto ok = pump->write(argv[3], std::span(&value, 1)); !ok) {
                return fail(ok.error());
            }
            std::printf("ok %u\n", value);
        }
        (void)pump->release_control();
        return 0;
    }
    if (mode == "broadcast" && argc >= 5) {
        std::vector<std::uint16_t> values;
        for (int i = 4; i < argc; ++i) {
            values.push_back(static_cast<std::uint16_t>(std::strtoul(argv[i], nullptr, 0)));
        }
        const auto address = static_cast<std::uint16_t>(std::strtoul(argv[3], nullptr, 0));
        if (auto ok = bus->broadcast(address, values); !ok) {
            return fail(ok.error());
        }
        std::printf("sent\n");
        return 0;
    }
    if (mode == "take" && argc == 4) {
        // A controller's start, retried on QueueFull as an application would: the reference,
        // then the run command; "took tries T ms M" (M: the successful try's time), then
        // gives the lease back.
        const auto hz = static_cast<std::uint16_t>(std::atoi(argv[3]) * 100);
        const std::uint16_t run = 0xC400;
        for (int tries = 1; tries <= 500; ++tries) {
            const auto start = std::chrono::steady_clock::now();
            auto ok = pump->write("FA01", std::span(&hz, 1));
            if (ok) {
                ok = pump->write("FA00", std::span(&run, 1));
            }
            const auto took = std::chrono::steady_clock::now() - start;
            if (ok) {
                std::printf(
                    "took tries %d ms %lld\n", tries,
                    static_cast<long long>(std::chrono::duration_cast<std::chrono::milliseconds>(took).count()));
                (void)pump->release_control();
                return 0;
            }
            if (ok.error().kind != drivebus::ErrorKind::QueueFull) {
                return fail(ok.error());
            }
        }
        std::printf("never took it in 500 tries\n");
        return 1;
    }
    if (mode == "flood" && argc == 4) {
        bool first = true;
        for (;;) {
            auto v = read_on_a_busy_machine(*pump, argv[3]);
            if (!v) {
                return fail(v.error());
            }
            if (first) {
                std::printf("ready\n");
                first = false;
            }
        }
    }
    if (mode == "churn" && argc == 5) {
        // Reads of FE35 and writes of FA51 (from FIRST on, one new value each), alternating at
        // random, carrying on after errors: "read V", "wrote V", "error KIND" / "unknown V KIND"
        // for a write whose outcome is unknown; "done" at the end.
        const int count = std::atoi(argv[3]);
        auto value = static_cast<std::uint16_t>(std::strtoul(argv[4], nullptr, 0));
        std::uint32_t x = value * 2654435761U + 1;
        for (int i = 0; i < count; ++i) {
            x = x * 1664525U + 1013904223U;
            if ((x >> 16) % 2 == 0) {
                auto v = pump->read("FE35");
                if (v) {
                    std::printf("read %u\n", v->at(0));
                } else {
                    std::printf("error %s\n", std::string(drivebus::to_string(v.error().kind)).c_str());
                }
                continue;
            }
            if (auto ok = pump->write("FA51", std::span(&value, 1)); ok) {
                std::printf("wrote %u\n", value);
            } else {
                std::printf("unknown %u %s\n", value, std::string(drivebus::to_string(ok.error().kind)).c_str());
            }
            ++value;
        }
        std::printf("done\n");
        return 0;
    }
    if (mode == "lease" && argc == 3) {
        const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(5);
        std::uint64_t seen = 0;
        drivebus::shm::DriveSnapshot last{};
        while (std::chrono::steady_clock::now() < until) {
            auto s = pump->wait_snapshot(std::chrono::milliseconds(200), seen);
            if (!s) {
                continue;
            }
            seen = s->sequence;
            last = *s;
            if (last.lease.state == drivebus::shm::LeaseState::Expired && last.lease.fallback_ok != 0) {
                break;
            }
        }
        std::printf("lease %s holder %s fallback_ok %u registers %u\n",
                    std::string(drivebus::shm::to_string(last.lease.state)).c_str(),
                    drivebus::shm::view(last.lease.holder).empty() ? "none" : "kept",
                    static_cast<unsigned>(last.lease.fallback_ok), static_cast<unsigned>(last.register_count));
        return last.lease.state == drivebus::shm::LeaseState::Expired ? 0 : 1;
    }
    if (mode == "impostor" && argc == 4) {
        const auto id = std::strtoull(argv[3], nullptr, 10);
        const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(10);
        std::optional<drivebus::shm::LeaseStatus> held;
        while (!held && std::chrono::steady_clock::now() < until) {
            auto s = pump->wait_snapshot(std::chrono::milliseconds(200));
            if (s && s->lease.state == drivebus::shm::LeaseState::Held) {
                held = s->lease;
            }
        }
        if (!held) {
            std::fprintf(stderr, "test_client: no held lease seen\n");
            return 1;
        }
        bool refused = true;
        for (const drivebus::shm::LeaseToken token : {drivebus::shm::LeaseToken{}, drivebus::shm::LeaseToken{id, id}}) {
            for (const auto kind : {drivebus::shm::RequestKind::Write, drivebus::shm::RequestKind::LeaseRenew,
                                    drivebus::shm::RequestKind::LeaseRelease}) {
                drivebus::shm::Request r;
                r.kind = kind;
                r.client = id;
                r.client_name = held->holder;
                r.pid = held->holder_pid;
                r.lease_token = token;
                drivebus::shm::assign(r.drive, "pump");
                r.start = 0xFA00;
                r.count = kind == drivebus::shm::RequestKind::Write ? 1 : 0;
                r.values[0] = 0xC800;
                auto response = bus->request(r);
                if (!response) {
                    return fail(response.error());
                }
                const char* what = kind == drivebus::shm::RequestKind::Write        ? "write"
                                   : kind == drivebus::shm::RequestKind::LeaseRenew ? "renew"
                                                                                    : "release";
                std::printf("%s %s\n", what, std::string(drivebus::shm::to_string(response->status)).c_str());
                refused = refused && response->status == drivebus::shm::Status::NotPermitted;
            }
        }
        return refused ? 0 : 1;
    }
    if (mode == "frequency" && argc == 5) {
        auto drive = bus->drive(argv[3]);
        if (!drive) {
            return fail(drive.error());
        }
        const drivebus::Altivar altivar(*drive);
        if (auto ok = altivar.set_frequency(std::atof(argv[4])); !ok) {
            return fail(ok.error());
        }
        [[maybe_unused]] const auto released = drive->release_control();
        std::printf("set\n");
        return 0;
    }
    if ((mode == "command" || mode == "hang") && argc == 4) {
        const drivebus::Altivar altivar(*pump);
        if (auto ok = altivar.set_frequency(std::atof(argv[3])); !ok) {
            return fail(ok.error());
        }
        if (auto ok = altivar.run_forward(); !ok) {
            return fail(ok.error());
        }
        std::printf("holding\n");
        std::printf("client %llu\n", static_cast<unsigned long long>(bus->client_id()));
        if (mode == "command") {
            control_loop(*pump, std::nullopt);
        }
        // The hung application: its control thread blocks, everything else of the process runs.
        std::thread control([&] { control_loop(*pump, 500U); });
        control.detach();
        std::uint64_t seen = 0;
        bool told = false;
        for (;;) {
            auto s = pump->wait_snapshot(std::chrono::milliseconds(200), seen);
            if (!s) {
                continue;
            }
            seen = s->sequence;
            if (!told && s->lease.state == drivebus::shm::LeaseState::Expired && s->lease.fallback_ok != 0) {
                std::printf("expired %lld fallback_ok %u\n", static_cast<long long>(s->lease.expired_ns),
                            static_cast<unsigned>(s->lease.fallback_ok));
                told = true;
            }
        }
    }
    std::fprintf(stderr, "test_client: bad arguments for mode %s\n", mode.c_str());
    return 2;
}
