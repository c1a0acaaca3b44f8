// SPDX-License-Identifier: Apache-2.0
// The floor under drivebus's shared-memory hop: a bare iceoryx publisher and a subscriber with
// a Listener, in two processes, passing a sample the size of a drive snapshot. What it measures
// is iceoryx's own cost on this machine (loan, publish, the notification, the Listener thread's
// wake-up), with no drivebus code on the path. Needs a RouDi.
//
//   bench_iox_floor sub N [BUS DRIVE]
//                                  prints N latencies in ns (publish → callback), one a line;
//                                  with BUS and DRIVE, of drivebusd's own snapshots of DRIVE
//   bench_iox_floor pub N PAUSE_US publishes until the subscriber has gone, or N + 1000 samples
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "drivebus/shm.hpp"
#include "iceoryx_posh/popo/listener.hpp"
#include "iceoryx_posh/popo/publisher.hpp"
#include "iceoryx_posh/popo/subscriber.hpp"
#include "iceoryx_posh/runtime/posh_runtime.hpp"

namespace {

// A drive snapshot's size, with the publication time where drivebusd keeps it.
using Sample = drivebus::shm::DriveSnapshot;

const iox::capro::ServiceDescription kService{"drivebus-bench", "floor", "snapshot"};

std::int64_t now_ns() {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
        .count();
}

int subscribe(std::size_t wanted, const iox::capro::ServiceDescription& service) {
    iox::runtime::PoshRuntime::initRuntime("bench-iox-floor-sub");
    iox::popo::SubscriberOptions options;
    options.queueCapacity = 2;
    iox::popo::Subscriber<Sample> subscriber(service, options);
    std::mutex mutex;
    std::vector<std::int64_t> latencies;
    latencies.reserve(wanted);
    iox::popo::Listener listener;
    struct Context {
        std::mutex* mutex;
        std::vector<std::int64_t>* latencies;
    } context{&mutex, &latencies};
    auto arrived = [](iox::popo::Subscriber<Sample>* s, Context* c) {
        for (;;) {
            auto taken = s->take();
            if (taken.has_error()) {
                return;
            }
            const std::int64_t latency = now_ns() - taken.value()->published_ns;
            const std::lock_guard lock(*c->mutex);
            c->latencies->push_back(latency);
        }
    };
    (void)listener.attachEvent(subscriber, iox::popo::SubscriberEvent::DATA_RECEIVED,
                               iox::popo::createNotificationCallback(*arrived, context));
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30 + wanted / 100);
    for (;;) {
        {
            const std::lock_guard lock(mutex);
            if (latencies.size() >= wanted) {
                break;
            }
        }
        if (std::chrono::steady_clock::now() > deadline) {
            std::fprintf(stderr, "bench_iox_floor: only %zu of %zu samples\n", latencies.size(), wanted);
            return 1;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    listener.detachEvent(subscriber, iox::popo::SubscriberEvent::DATA_RECEIVED);
    const std::lock_guard lock(mutex);
    for (std::size_t i = 0; i < wanted; ++i) {
        std::printf("%lld\n", static_cast<long long>(latencies[i]));
    }
    return 0;
}

int publish(std::size_t count, int pause_us) {
    iox::runtime::PoshRuntime::initRuntime("bench-iox-floor-pub");
    iox::popo::Publisher<Sample> publisher(kService);
    // Until the subscriber is connected, samples would go nowhere.
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (!publisher.hasSubscribers()) {
        if (std::chrono::steady_clock::now() > deadline) {
            std::fprintf(stderr, "bench_iox_floor: no subscriber\n");
            return 1;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    for (std::size_t i = 0; i < count + 1000 && publisher.hasSubscribers(); ++i) {
        std::this_thread::sleep_for(std::chrono::microseconds(pause_us));
        auto sample = publisher.loan();
        if (sample.has_error()) {
            continue;
        }
        sample.value()->published_ns = now_ns();
        sample.value().publish();
    }
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    const std::string mode = argc > 2 ? argv[1] : "";
    if (mode == "sub" && argc == 3) {
        return subscribe(static_cast<std::size_t>(std::atol(argv[2])), kService);
    }
    if (mode == "sub" && argc == 5) {
        const std::string event = std::string(drivebus::shm::kDriveEventPrefix) + argv[4];
        return subscribe(static_cast<std::size_t>(std::atol(argv[2])),
                         {iox::capro::IdString_t(iox::cxx::TruncateToCapacity, std::string(drivebus::shm::kService)),
                          iox::capro::IdString_t(iox::cxx::TruncateToCapacity, argv[3]),
                          iox::capro::IdString_t(iox::cxx::TruncateToCapacity, event)});
    }
    if (mode == "pub" && argc == 4) {
        return publish(static_cast<std::size_t>(std::atol(argv[2])), std::atoi(argv[3]));
    }
    std::fprintf(stderr, "usage: bench_iox_floor sub N [BUS DRIVE] | pub N PAUSE_US\n");
    return 2;
}
