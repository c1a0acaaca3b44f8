// SPDX-License-Identifier: Apache-2.0
// Every request gets exactly one answer (the intake's decisions and the real bus thread, no
// RouDi): requests the intake refuses are answered at once, requests the bus refuses later
// (bus down) come back through the results ring and are answered then, and the pending book
// returns to empty, so memory stays flat however many are refused.
#include <gtest/gtest.h>
#include <poll.h>

#include <fstream>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "bus/bus_loop.hpp"
#include "fixtures.hpp"
#include "ipc/intake_core.hpp"
#include "sim_process.hpp"

namespace drivebus::test {
namespace {

using namespace std::chrono_literals;

// The test's "route" for each request: its number, to count its answers.
using Route = ipc::RouteId;

shm::Request read_fd00(std::uint64_t client) {
    shm::Request r;
    r.size = sizeof r;
    r.kind = shm::RequestKind::Read;
    r.client = client;
    r.correlation = client;
    shm::assign(r.drive, "pump");
    shm::assign(r.client_name, "flood");
    r.start = 0xFD00;
    r.count = 1;
    return r;
}

long rss_anon_kb() {
    std::ifstream in("/proc/self/status");
    for (std::string line; std::getline(in, line);) {
        if (line.rfind("RssAnon:", 0) == 0) {
            return std::stol(line.substr(8));
        }
    }
    return -1;
}

class Answers : public ::testing::Test {
protected:
    std::shared_ptr<const Profile> atv21 = load("atv21");
    config::BusConfig config = bus<config::BusConfig>();
    std::unique_ptr<bus::BusLoop> loop;
    std::unique_ptr<ipc::LeasePolicy> leases;
    std::unique_ptr<ipc::IntakeCore> intake;
    std::vector<unsigned> answers;  // per request
    std::map<shm::Status, std::size_t> statuses;
    std::vector<shm::Status> last;  // each route's last answer

    void start(const std::filesystem::path& device) {
        config.device = device;
        config.drives.push_back(drive("pump", 1, atv21));
        loop = std::make_unique<bus::BusLoop>(config, master::EngineCallbacks{});
        ASSERT_TRUE(loop->start().has_value());
        leases = std::make_unique<ipc::LeasePolicy>(
            config, [n = std::uint64_t{0}]() mutable { return shm::LeaseToken{++n, 1}; });
        intake = std::make_unique<ipc::IntakeCore>(
            config, *leases, [this](const master::ClientRequest& r) { return loop->submit(r).has_value(); });
    }
    void TearDown() override {
        if (loop) {
            loop->stop();
        }
    }
    // One request from `client`; `bus_up` as the intake believes it (the bus may know better).
    void send(std::uint64_t client, bool bus_up = true) {
        Route route = answers.size();
        answers.push_back(0);
        last.push_back(shm::Status::Ok);
        if (const auto now = intake->accept(read_fd00(client), route, bus_up, sys::now())) {
            count(route, *now);
        }
    }
    void count(Route route, const shm::Response& r) {
        ++answers.at(route);
        ++statuses[r.status];
        last.at(route) = r.status;
    }
    // A request on a route of its own; returns the route.
    Route ask(const shm::Request& r) {
        Route route = answers.size();
        answers.push_back(0);
        last.push_back(shm::Status::Ok);
        if (const auto now = intake->accept(r, route, true, sys::now())) {
            count(route, *now);
        }
        return route;
    }
    // Hands back what the bus has for the intake until `done` holds (or the deadline).
    bool pump_until(const std::function<bool()>& done, std::chrono::milliseconds timeout = 20s) {
        auto& h = loop->handover();
        const auto deadline = sys::now() + timeout;
        while (!done() && sys::now() < deadline) {
            pollfd p{h.ready_fd(), POLLIN, 0};
            (void)::poll(&p, 1, 20);
            h.acknowledge();
            master::Finished f;
            while (h.results.try_pop(f)) {
                if (auto a = intake->finish(f)) {
                    if (a->entry.route) {
                        count(*a->entry.route, a->response);
                    }
                    if (a->entry.withdrawal) {
                        count(*a->entry.withdrawal, a->response);
                    }
                }
            }
        }
        return done();
    }
    // Answers what the bus handed back, until nothing is in flight (or the deadline).
    bool drain(std::chrono::milliseconds timeout = 20s) {
        auto& h = loop->handover();
        const auto deadline = sys::now() + timeout;
        while (intake->book().size() > 0 && sys::now() < deadline) {
            pollfd p{h.ready_fd(), POLLIN, 0};
            (void)::poll(&p, 1, 100);
            h.acknowledge();
            master::Finished f;
            while (h.results.try_pop(f)) {
                auto a = intake->finish(f);
                if (a && a->entry.route) {
                    count(*a->entry.route, a->response);
                }
                if (a && a->entry.withdrawal) {
                    count(*a->entry.withdrawal, a->response);
                }
            }
        }
        return intake->book().size() == 0;
    }
    void expect_each_answered_once() {
        std::size_t wrong = 0;
        for (const auto n : answers) {
            wrong += n != 1 ? 1 : 0;
        }
        EXPECT_EQ(wrong, 0U) << "of " << answers.size() << " requests";
    }
};

TEST_F(Answers, RequestsTheBusRefusesAreAnsweredOnceAndMemoryStaysFlat) {
    // No such device: the line stays down, and the bus thread refuses every request it takes.
    start("/nonexistent/drivebus-tty");
    constexpr std::size_t kTotal = 100'000;
    long warm = 0;
    for (std::size_t i = 0; i < kTotal; ++i) {
        send(i % 20);
        if (intake->book().clients_in_flight() >= intake->book().shared_room()) {
            ASSERT_TRUE(drain()) << intake->book().size() << " requests never answered";
        }
        if (i == kTotal / 10) {
            warm = rss_anon_kb();
        }
    }
    ASSERT_TRUE(drain()) << intake->book().size() << " requests never answered";
    expect_each_answered_once();
    EXPECT_EQ(statuses[shm::Status::BusDown], kTotal);
    EXPECT_EQ(intake->book().size(), 0U) << "every entry leaves the book with its answer";
    EXPECT_EQ(intake->served(), kTotal);
    // Besides the exact check above, the process's anonymous memory: flat within a generous
    // margin (the answers vector itself grows by 360 KB here).
    // (Not under AddressSanitizer: its quarantine keeps freed memory by design.)
    const long end = rss_anon_kb();
#if !defined(__SANITIZE_ADDRESS__)
    EXPECT_LT(end - warm, 4096) << "RssAnon grew from " << warm << " to " << end << " kB";
#else
    (void)warm;
    (void)end;
#endif
}

TEST_F(Answers, AFloodOfManyClientsIsAnsweredRequestForRequest) {
    SimProcess sim({"--drive", "1:atv21", "--no-pace"});
    config.queue_limit = 16;
    start(sim.link());
    ASSERT_TRUE(wait_until([&] { return loop->up(); }, 10s));
    // 20 clients with 12 requests each in flight at once, five times over.
    std::size_t sent = 0;
    for (int round = 0; round < 5; ++round) {
        for (int k = 0; k < 12; ++k) {
            for (std::uint64_t client = 1; client <= 20; ++client) {
                send(client);
                ++sent;
            }
        }
        ASSERT_TRUE(drain()) << intake->book().size() << " requests never answered";
    }
    expect_each_answered_once();
    EXPECT_EQ(answers.size(), sent);
    EXPECT_EQ(statuses[shm::Status::QueueFull] + statuses[shm::Status::Ok], sent)
        << "ok " << statuses[shm::Status::Ok] << ", queue full " << statuses[shm::Status::QueueFull];
    EXPECT_GE(statuses[shm::Status::Ok], 5U * intake->book().shared_room()) << "reads fill the shared room";
    EXPECT_EQ(loop->status().counters.queue_rejections, 0U) << "the one limit is the intake's";
    EXPECT_EQ(intake->queue_full(), statuses[shm::Status::QueueFull]) << "and the intake counts what it refuses";
}

shm::Request write_fa51(std::uint64_t correlation, std::uint16_t value) {
    shm::Request r;
    r.size = sizeof r;
    r.kind = shm::RequestKind::Write;
    r.client = 7;
    r.correlation = correlation;
    shm::assign(r.drive, "pump");
    shm::assign(r.client_name, "withdrawer");
    r.start = 0xFA51;
    r.count = 1;
    r.values[0] = value;
    return r;
}

shm::Request withdrawal_of(shm::Request r) {
    r.kind = shm::RequestKind::Withdraw;
    return r;
}

// A client that gives up withdraws its request: one still queued is never sent and both the
// request and its withdrawal are answered Withdrawn; one already on the wire is answered Sent
// (its outcome unknown to the client), then its own result comes; a withdrawal of a request
// drivebusd does not hold is answered NotPending. The simulator's register says what reached it.
TEST_F(Answers, AWithdrawnRequestIsNeverSentAndOneOnTheWireIsSaidToBe) {
    SimProcess sim({"--drive", "1:atv21", "--no-pace"});
    ASSERT_EQ(sim.command("set 1 F803 0").rfind("ok", 0), 0U);
    ASSERT_EQ(sim.command("fault 1 late=150ms").rfind("ok", 0), 0U);  // each transaction takes 150 ms
    config.response_timeout = std::chrono::milliseconds(500);
    start(sim.link());
    ASSERT_TRUE(wait_until([&] { return loop->up(); }, 10s));

    // A first write occupies the line; the second waits behind it and is withdrawn.
    const Route first = ask(write_fa51(1, 111));
    ASSERT_TRUE(wait_until([&] { return loop->status().counters.transmissions > 0; }, 10s));
    const Route queued = ask(write_fa51(2, 777));
    const Route withdrawal = ask(withdrawal_of(write_fa51(2, 777)));
    ASSERT_TRUE(pump_until([&] { return answers[queued] > 0 && answers[withdrawal] > 0 && answers[first] > 0; }));
    EXPECT_EQ(last[queued], shm::Status::Withdrawn);
    EXPECT_EQ(last[withdrawal], shm::Status::Withdrawn);
    EXPECT_EQ(last[first], shm::Status::Ok);

    // One on the wire: the withdrawal is told Sent, the request gets its own result.
    // On the wire once the drive has it (the bus may send reads of its own between, such as the
    // drive's Modbus time-out once it answers: a transmission counted proves nothing).
    const Route on_wire = ask(write_fa51(3, 555));
    ASSERT_TRUE(wait_until([&] { return sim.command("requests 1").find(" 06:0xFA51=555") != std::string::npos; }, 10s));
    const Route late_withdrawal = ask(withdrawal_of(write_fa51(3, 555)));
    // One withdrawal per request: a second is answered at once and reaches no ring.
    const Route again = ask(withdrawal_of(write_fa51(3, 555)));
    EXPECT_EQ(answers[again], 1U);
    EXPECT_EQ(last[again], shm::Status::Rejected);
    ASSERT_TRUE(pump_until([&] { return answers[on_wire] > 0 && answers[late_withdrawal] > 0; }));
    EXPECT_EQ(last[late_withdrawal], shm::Status::Sent);
    EXPECT_EQ(last[on_wire], shm::Status::Ok);

    // Nothing pending under that correlation any more.
    const Route stray = ask(withdrawal_of(write_fa51(3, 555)));
    EXPECT_EQ(last[stray], shm::Status::Rejected);
    EXPECT_EQ(intake->book().size(), 0U);
    expect_each_answered_once();
    EXPECT_EQ(sim.command("get 1 FA51"), "ok 555") << "the withdrawn 777 never reached the drive";
}

TEST_F(Answers, TheIntakeAnswersBusDownWithoutBookingWhenItKnowsTheLineIsDown) {
    start("/nonexistent/drivebus-tty");
    for (int i = 0; i < 100; ++i) {
        send(1, false);
    }
    expect_each_answered_once();
    EXPECT_EQ(statuses[shm::Status::BusDown], 100U);
    EXPECT_EQ(intake->book().size(), 0U);
}

}  // namespace
}  // namespace drivebus::test
