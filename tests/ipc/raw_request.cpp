// SPDX-License-Identifier: Apache-2.0
// Asks iceoryx directly, without libdrivebus and its group check, for a request chunk on a
// bus's request server and sends one write (pump's FA51 = VALUE):
//   raw_request BUS VALUE
// Prints "answered STATUS" and exits 0 when drivebusd answered Ok; anything else is non-zero.
//   raw_request BUS keep N
// Keeps N reads of the pump's FD00 in flight until killed (each answer sends the next).
//   raw_request BUS flood N [GO]
// Sends N reads of the pump's FD00 at once (N <= 16, a client's response queue), then takes
// the answers for up to 20 s: "answers A of N ok O full F line L other X duplicates D"; exits 0
// when every request was answered exactly once. `line` counts what a busy line or machine may
// answer (time-out, bad frame, late, bus down), `other` everything else. With GO, it prints
// "connected" once connected and sends only when the file GO exists, so that many clients can
// send at the same moment.
//   raw_request BUS rotate N
// As flood, each request with another client id (1000, 1001, ...): one port all the same.
//   raw_request BUS spam [SECONDS]
// Keeps 8 requests in flight until killed (or for SECONDS, then prints "answered N"), sending the next as soon as an
// answer comes, without a pause: much of its time is spent inside iceoryx's send(), where a SIGKILL leaves locks held.
// They name no drive of the bus, so drivebusd refuses them at once and the line stays free for others. Prints
// "spamming" after its first answer.
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include "drivebus/shm.hpp"
#include "iceoryx_posh/popo/untyped_client.hpp"
#include "iceoryx_posh/runtime/posh_runtime.hpp"

namespace {

int flood(iox::popo::UntypedClient& client, int n, bool rotate = false) {
    using namespace drivebus;
    for (int i = 0; i < n; ++i) {
        auto loaned = client.loan(sizeof(shm::Request), alignof(shm::Request));
        if (loaned.has_error()) {
            std::printf("no request chunk: error %d\n", static_cast<int>(loaned.get_error()));
            return 3;
        }
        shm::Request r;
        r.size = sizeof r;
        r.kind = shm::RequestKind::Read;
        r.correlation = static_cast<std::uint64_t>(i);
        // Rotating: another client id in each request, as a client escaping its share would.
        r.client = rotate ? static_cast<std::uint64_t>(1000 + i) : static_cast<std::uint64_t>(::getpid());
        shm::assign(r.drive, "pump");
        shm::assign(r.client_name, "raw_request flood");
        r.start = 0xFD00;
        r.count = 1;
        std::memcpy(loaned.value(), &r, sizeof r);
        if (client.send(loaned.value()).has_error()) {
            std::printf("send refused\n");
            return 4;
        }
    }
    std::vector<int> answers(static_cast<std::size_t>(n), 0);
    int total = 0;
    int ok = 0;
    int full = 0;
    int line = 0;
    int other = 0;
    int duplicates = 0;
    const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while (total < n && std::chrono::steady_clock::now() < until) {
        auto taken = client.take();
        if (taken.has_error()) {
            std::this_thread::sleep_for(std::chrono::milliseconds(1));
            continue;
        }
        shm::Response response{};
        std::memcpy(&response, taken.value(), sizeof response);
        client.releaseResponse(taken.value());
        if (response.correlation >= answers.size() || answers[response.correlation]++ > 0) {
            ++duplicates;
            continue;
        }
        ++total;
        ok += response.status == shm::Status::Ok ? 1 : 0;
        full += response.status == shm::Status::QueueFull ? 1 : 0;
        switch (response.status) {
        case shm::Status::Ok:
        case shm::Status::QueueFull: break;
        case shm::Status::Timeout:
        case shm::Status::BadFrame:
        case shm::Status::Late:
        case shm::Status::BusDown: ++line; break;
        default: ++other; break;
        }
    }
    std::printf("answers %d of %d ok %d full %d line %d other %d duplicates %d\n", total, n, ok, full, line, other,
                duplicates);
    return total == n && duplicates == 0 ? 0 : 5;
}

// Keeps `n` reads of the pump's FD00 in flight until killed: each answer is followed by a new
// read. "flooding" once n are out; every 100 answers "answers A full F".
int keep(iox::popo::UntypedClient& client, int n) {
    using namespace drivebus;
    std::uint64_t next = 0;
    const auto send_one = [&] {
        auto loaned = client.loan(sizeof(shm::Request), alignof(shm::Request));
        if (loaned.has_error()) {
            return false;
        }
        shm::Request r;
        r.size = sizeof r;
        r.kind = shm::RequestKind::Read;
        r.correlation = next++;
        r.client = static_cast<std::uint64_t>(::getpid());
        shm::assign(r.drive, "pump");
        shm::assign(r.client_name, "raw_request keep");
        r.start = 0xFD00;
        r.count = 1;
        std::memcpy(loaned.value(), &r, sizeof r);
        return !client.send(loaned.value()).has_error();
    };
    for (int i = 0; i < n; ++i) {
        if (!send_one()) {
            return 4;
        }
    }
    std::printf("flooding\n");
    std::fflush(stdout);
    std::uint64_t answers = 0;
    std::uint64_t full = 0;
    for (;;) {
        auto taken = client.take();
        if (taken.has_error()) {
            std::this_thread::sleep_for(std::chrono::microseconds(200));
            continue;
        }
        shm::Response response{};
        std::memcpy(&response, taken.value(), sizeof response);
        client.releaseResponse(taken.value());
        ++answers;
        full += response.status == shm::Status::QueueFull ? 1 : 0;
        if (answers % 100 == 0) {
            std::printf("answers %llu full %llu\n", static_cast<unsigned long long>(answers),
                        static_cast<unsigned long long>(full));
            std::fflush(stdout);
        }
        if (!send_one()) {
            return 4;
        }
    }
}

bool send_read(iox::popo::UntypedClient& client, std::uint64_t correlation) {
    using namespace drivebus;
    auto loaned = client.loan(sizeof(shm::Request), alignof(shm::Request));
    if (loaned.has_error()) {
        return false;
    }
    shm::Request r;
    r.size = sizeof r;
    r.kind = shm::RequestKind::Read;
    r.correlation = correlation;
    r.client = static_cast<std::uint64_t>(::getpid());
    shm::assign(r.drive, "pump");
    shm::assign(r.client_name, "raw_request spam");
    shm::assign(r.drive, "nobody");
    r.start = 0xFD00;
    r.count = 1;
    std::memcpy(loaned.value(), &r, sizeof r);
    return !client.send(loaned.value()).has_error();
}

// Until killed, or for `seconds` when given: then "answered N", and 0 when N > 0.
int spam(iox::popo::UntypedClient& client, int seconds) {
    constexpr int kInFlight = 8;
    const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(seconds);
    std::uint64_t correlation = 0;
    std::uint64_t answered = 0;
    int in_flight = 0;
    for (;;) {
        while (in_flight < kInFlight && send_read(client, ++correlation)) {
            ++in_flight;
        }
        auto taken = client.take();
        if (taken.has_error()) {
            if (seconds > 0) {
                if (std::chrono::steady_clock::now() >= until) {
                    break;
                }
                // Timed, it leaves the cores to others between answers: its iceoryx runtime's
                // keep-alive too, which RouDi wants at least each 1.5 s, however loaded.
                std::this_thread::sleep_for(std::chrono::microseconds(100));
            }
            continue;
        }
        client.releaseResponse(taken.value());
        --in_flight;
        if (++answered == 1) {
            std::printf("spamming\n");
            std::fflush(stdout);
        }
    }
    std::printf("answered %llu\n", static_cast<unsigned long long>(answered));
    return answered > 0 ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
    const bool flooding = (argc == 4 || argc == 5) && std::string(argv[2]) == "flood";
    const bool rotating = argc == 4 && std::string(argv[2]) == "rotate";
    const bool keeping = argc == 4 && std::string(argv[2]) == "keep";
    const bool spamming = (argc == 3 || argc == 4) && std::string(argv[2]) == "spam";
    if (argc != 3 && !flooding && !keeping && !spamming && !rotating) {
        std::fprintf(stderr,
                     "usage: raw_request BUS VALUE | raw_request BUS flood N [GO] | raw_request BUS keep N | "
                     "raw_request BUS spam [SECONDS] | raw_request BUS rotate N\n");
        return 2;
    }
    using namespace drivebus;
    const std::string name = "raw_request-" + std::to_string(::getpid());
    iox::runtime::PoshRuntime::initRuntime(iox::RuntimeName_t(iox::cxx::TruncateToCapacity, name.c_str()));
    iox::popo::UntypedClient client(
        {"drivebus", iox::capro::IdString_t(iox::cxx::TruncateToCapacity, argv[1]), "requests"});
    const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(argc == 5 ? 30 : 3);
    while (client.getConnectionState() != iox::ConnectionState::CONNECTED && std::chrono::steady_clock::now() < until) {
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    if (rotating) {
        return flood(client, std::atoi(argv[3]), true);
    }
    if (keeping) {
        return keep(client, std::atoi(argv[3]));
    }
    if (spamming) {
        return spam(client, argc == 4 ? std::atoi(argv[3]) : 0);
    }
    if (flooding) {
        if (argc == 5) {
            std::printf("connected\n");
            std::fflush(stdout);
            const auto go_by = std::chrono::steady_clock::now() + std::chrono::seconds(60);
            while (::access(argv[4], F_OK) != 0 && std::chrono::steady_clock::now() < go_by) {
                std::this_thread::sleep_for(std::chrono::milliseconds(1));
            }
        }
        return flood(client, std::atoi(argv[3]));
    }
    auto loaned = client.loan(sizeof(shm::Request), alignof(shm::Request));
    if (loaned.has_error()) {
        std::printf("no request chunk: error %d\n", static_cast<int>(loaned.get_error()));
        return 3;
    }
    shm::Request r;
    r.size = sizeof r;
    r.kind = shm::RequestKind::Write;
    r.correlation = 1;
    r.client = 77;
    shm::assign(r.drive, "pump");
    r.start = 0xFA51;
    r.count = 1;
    r.values[0] = static_cast<std::uint16_t>(std::atoi(argv[2]));
    std::memcpy(loaned.value(), &r, sizeof r);
    if (client.send(loaned.value()).has_error()) {
        std::printf("send refused\n");
        return 4;
    }
    const auto answer_by = std::chrono::steady_clock::now() + std::chrono::seconds(3);
    while (std::chrono::steady_clock::now() < answer_by) {
        auto taken = client.take();
        if (!taken.has_error()) {
            shm::Response response{};
            std::memcpy(&response, taken.value(), sizeof response);
            client.releaseResponse(taken.value());
            std::printf("answered %s (%s)\n", std::string(shm::to_string(response.status)).c_str(),
                        std::string(shm::to_string(response.reason)).c_str());
            return response.status == shm::Status::Ok ? 0 : 5;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    std::printf("no answer\n");
    return 6;
}
