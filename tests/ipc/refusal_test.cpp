// SPDX-License-Identifier: Apache-2.0
// A refused request changes nothing: whatever refuses a write to the pump's command or reference
// (admission, an expired deadline, the line down, a full queue, or the bus thread afterwards:
// a block not applied, withdrawn, expired, the line gone down while it waited), the control
// lease afterwards, and every fallback that follows, are those of a twin that never saw the
// request. Pure: IntakeCore and LeasePolicy on a fake bus and a jumping clock.
#include <gtest/gtest.h>

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "config/config.hpp"
#include "ipc/convert.hpp"
#include "ipc/intake_core.hpp"
#include "read_bus.hpp"

namespace drivebus::ipc {
namespace {

using namespace std::chrono_literals;
using Route = RouteId;

config::BusConfig pump_bus() {
    return test::read_bus(
        test::pump_toml({R"(lease = "500ms")", R"(fallback = "stop")", R"(write_block = ["FA00", "FA01"])"}));
}

const rtu::Instant t0{std::chrono::seconds(100)};

shm::Request write(std::uint64_t client, std::uint16_t start, std::vector<std::uint16_t> values) {
    shm::Request r;
    r.size = sizeof r;
    r.kind = shm::RequestKind::Write;
    r.client = client;
    r.correlation = client * 1000 + start;
    shm::assign(r.drive, "pump");
    shm::assign(r.client_name, "client-" + std::to_string(client));
    r.pid = static_cast<std::int32_t>(client);
    r.start = start;
    r.count = static_cast<std::uint16_t>(values.size());
    std::ranges::copy(values, r.values.begin());
    return r;
}

// One drivebusd's intake and leases, with a bus that takes everything and answers when told.
struct World {
    config::BusConfig bus = pump_bus();
    LeasePolicy leases{bus, [n = std::uint64_t{0}]() mutable { return shm::LeaseToken{++n, 7}; }};
    std::vector<master::ClientRequest> submitted;
    IntakeCore intake{bus, leases, [this](const master::ClientRequest& r) {
                          submitted.push_back(r);
                          return true;
                      }};
    std::vector<std::string> fallbacks;  // "time drive" of each fallback write

    // Accepts `r`; nullopt: booked, and the bus has it (submitted.back()).
    std::optional<shm::Response> accept(const shm::Request& r, rtu::Instant now, bool bus_up = true) {
        Route route = 0;
        return intake.accept(r, route, bus_up, now);
    }
    shm::Response finish(const master::Finished& f) {
        auto a = intake.finish(f);
        EXPECT_TRUE(a.has_value());
        return a ? a->response : shm::Response{};
    }
    shm::Response ok(std::uint64_t id) {
        master::Finished f;
        f.id = id;
        f.outcome = master::Outcome::Ok;
        return finish(f);
    }
    // A write by `client` (with its token, if it holds one) that the bus performs.
    shm::LeaseToken command(std::uint64_t client, rtu::Instant now, shm::LeaseToken token = {}) {
        auto r = write(client, 0xFA00, {0xC400});
        r.lease_token = token;
        EXPECT_FALSE(accept(r, now).has_value());
        return ok(submitted.back().correlation).lease_token;
    }
    void expire(rtu::Instant now) {
        for (const auto& f : leases.expire(now)) {
            fallbacks.push_back(std::to_string((now - t0) / 1ms) + " " + std::to_string(f.drive) +
                                (f.write ? " write" : " hold"));
        }
    }
};

std::string lease_of(const World& w) {
    const auto s = w.leases.status(0);
    return std::string(shm::to_string(s.state)) + " holder '" + std::string(shm::view(s.holder)) + "' pid " +
           std::to_string(s.holder_pid) + " expires " + std::to_string(s.expires_ns) + " expiries " +
           std::to_string(s.expiries);
}

// Where the lease stands before the refused request (client 1 is A, 2 is B).
enum class Before { Free, HeldByA, RunningOutForA, ExpiredFromA };
// Who asks, and how.
enum class Asker { ARenewsDirect, ARenewsThroughTheBlock, BPlain, BTakesOver, BThroughTheBlock };
// What refuses it.
enum class Refusal {
    Admission,
    DeadlinePastAtIntake,
    BusDownAtIntake,
    QueueFullAtIntake,
    BlockNotApplied,
    BusDownOnTheBus,
    QueueFullOnTheBus,
    UnknownDriveOnTheBus,
    Withdrawn,
    ExpiredOnTheBus,
    LineWentDownWhileItWaited,
};

// Sets `w`'s lease up as `before` says; returns A's token, if any.
shm::LeaseToken set_up(World& w, Before before) {
    switch (before) {
    case Before::Free: return {};
    case Before::HeldByA: return w.command(1, t0);
    case Before::RunningOutForA: return w.command(1, t0 - 450ms);
    case Before::ExpiredFromA: {
        const auto token = w.command(1, t0 - 700ms);
        w.expire(t0 - 100ms);
        return token;
    }
    }
    return {};
}

shm::Request ask(Asker asker, const shm::LeaseToken& a_token) {
    shm::Request r;
    switch (asker) {
    case Asker::ARenewsDirect:
        r = write(1, 0xFA01, {1500});
        r.lease_token = a_token;
        break;
    case Asker::ARenewsThroughTheBlock:
        r = write(1, 0x1870, {0xC400, 1500});
        r.lease_token = a_token;
        break;
    case Asker::BPlain: r = write(2, 0xFA00, {0xC400}); break;
    case Asker::BTakesOver:
        r = write(2, 0xFA00, {0xC400});
        r.flags = shm::kFlagTakeOver;
        break;
    case Asker::BThroughTheBlock: r = write(2, 0x1870, {0xC400, 1500}); break;
    }
    r.correlation = 999;
    return r;
}

// Makes `w` refuse `r` at `now` as `how` says; returns the one answer.
shm::Response refuse(World& w, shm::Request r, Refusal how, rtu::Instant now) {
    const auto bus_refusal = [&](master::Refusal why) {
        auto at_once = w.accept(r, now);
        if (at_once) {
            return *at_once;  // refused at intake already (another holder's lease)
        }
        return w.finish(master::refused(w.submitted.back().correlation, why));
    };
    switch (how) {
    case Refusal::Admission: r.version = 99; return *w.accept(r, now);
    case Refusal::DeadlinePastAtIntake: r.deadline_ns = monotonic_ns(now) - 1; return *w.accept(r, now);
    case Refusal::BusDownAtIntake: return *w.accept(r, now, false);
    case Refusal::QueueFullAtIntake:
        // Writes of FA51 (no lease) from the asker until it has no room left: its share is taken.
        for (int i = 0; i < 2000; ++i) {
            if (w.accept(write(r.client, 0xFA51, {1}), now)) {
                break;
            }
        }
        return *w.accept(r, now);
    case Refusal::BlockNotApplied: return bus_refusal(master::Refusal::BlockUnconfirmed);
    case Refusal::BusDownOnTheBus: return bus_refusal(master::Refusal::BusDown);
    case Refusal::QueueFullOnTheBus: return bus_refusal(master::Refusal::QueueFull);
    case Refusal::UnknownDriveOnTheBus: return bus_refusal(master::Refusal::UnknownDrive);
    case Refusal::Withdrawn: return bus_refusal(master::Refusal::Withdrawn);
    case Refusal::ExpiredOnTheBus: return bus_refusal(master::Refusal::Expired);
    case Refusal::LineWentDownWhileItWaited: {
        if (auto at_once = w.accept(r, now)) {
            return *at_once;
        }
        master::Result down;
        down.outcome = master::Outcome::BusDown;
        down.unsent = true;
        down.finished = now;
        return w.finish(master::finished(w.submitted.back().correlation, down));
    }
    }
    return {};
}

TEST(ARefusedRequest, ChangesNoLeaseWhateverRefusesIt) {
    constexpr Before kBefore[] = {Before::Free, Before::HeldByA, Before::RunningOutForA, Before::ExpiredFromA};
    constexpr Asker kAskers[] = {Asker::ARenewsDirect, Asker::ARenewsThroughTheBlock, Asker::BPlain, Asker::BTakesOver,
                                 Asker::BThroughTheBlock};
    constexpr Refusal kRefusals[] = {
        Refusal::Admission,         Refusal::DeadlinePastAtIntake,     Refusal::BusDownAtIntake,
        Refusal::QueueFullAtIntake, Refusal::BlockNotApplied,          Refusal::BusDownOnTheBus,
        Refusal::QueueFullOnTheBus, Refusal::UnknownDriveOnTheBus,     Refusal::Withdrawn,
        Refusal::ExpiredOnTheBus,   Refusal::LineWentDownWhileItWaited};
    int cases = 0;
    for (const auto before : kBefore) {
        for (const auto asker : kAskers) {
            for (const auto how : kRefusals) {
                const auto where = "case before " + std::to_string(static_cast<int>(before)) + " asker " +
                                   std::to_string(static_cast<int>(asker)) + " refusal " +
                                   std::to_string(static_cast<int>(how));
                World seen;
                World twin;  // never sees the request
                const auto token = set_up(seen, before);
                (void)set_up(twin, before);
                const auto now = t0 + 10ms;
                const auto answer = refuse(seen, ask(asker, token), how, now);
                EXPECT_NE(answer.status, shm::Status::Ok) << where;
                EXPECT_EQ(answer.lease_ms, 0U) << where << ": a refused request is granted no lease";
                EXPECT_EQ(answer.lease_token, shm::LeaseToken{}) << where;
                EXPECT_EQ(lease_of(seen), lease_of(twin)) << where;
                // And as time goes on, the same fallbacks at the same times.
                for (auto t = now; t < t0 + 1500ms; t += 25ms) {
                    seen.expire(t);
                    twin.expire(t);
                    ASSERT_EQ(seen.fallbacks, twin.fallbacks) << where << " at +" << (t - t0) / 1ms << " ms";
                    ASSERT_EQ(lease_of(seen), lease_of(twin)) << where << " at +" << (t - t0) / 1ms << " ms";
                }
                ++cases;
            }
        }
    }
    EXPECT_EQ(cases, 4 * 5 * 11);
}

// Two writes under A's lease on their way to the wire, each sent or refused, in either order of
// the bus's answers: the lease ends as if only the sent ones had been made.
TEST(ARefusedRequest, IsUndoneWhateverTheOrderOfTheAnswersAroundIt) {
    for (int sent_mask = 0; sent_mask < 4; ++sent_mask) {
        for (const bool reversed : {false, true}) {
            const auto where = "sent " + std::to_string(sent_mask) + (reversed ? " answered in reverse" : "");
            World seen;
            World twin;
            const auto token = seen.command(1, t0);
            const auto twin_token = twin.command(1, t0);
            const rtu::Instant when[] = {t0 + 100ms, t0 + 200ms};
            std::vector<std::uint64_t> ids;
            for (int i = 0; i < 2; ++i) {
                auto r = write(1, 0xFA01, {static_cast<std::uint16_t>(1000 + i)});
                r.lease_token = token;
                ASSERT_FALSE(seen.accept(r, when[i]).has_value());
                ids.push_back(seen.submitted.back().correlation);
                if ((sent_mask & (1 << i)) != 0) {
                    auto same = r;
                    same.lease_token = twin_token;
                    ASSERT_FALSE(twin.accept(same, when[i]).has_value()) << where;
                    twin.ok(twin.submitted.back().correlation);
                }
            }
            for (int k = 0; k < 2; ++k) {
                const int i = reversed ? 1 - k : k;
                if ((sent_mask & (1 << i)) != 0) {
                    seen.ok(ids[static_cast<std::size_t>(i)]);
                } else {
                    (void)seen.finish(master::refused(ids[static_cast<std::size_t>(i)], master::Refusal::Withdrawn));
                }
            }
            EXPECT_EQ(lease_of(seen), lease_of(twin)) << where;
            for (auto t = t0 + 250ms; t < t0 + 1500ms; t += 25ms) {
                seen.expire(t);
                twin.expire(t);
                ASSERT_EQ(seen.fallbacks, twin.fallbacks) << where << " at +" << (t - t0) / 1ms << " ms";
            }
            EXPECT_EQ(seen.fallbacks.size(), 1U) << where;
        }
    }
}

// A take-over refused later gives the lease back to the holder it was taken from: the same
// holder, its token valid again, its deadline unchanged.
TEST(ARefusedRequest, GivesATakenOverLeaseBackToItsHolder) {
    World w;
    const auto a = w.command(1, t0);
    const auto held = lease_of(w);
    auto b = write(2, 0xFA00, {0xC400});
    b.flags = shm::kFlagTakeOver;
    ASSERT_FALSE(w.accept(b, t0 + 50ms).has_value());
    EXPECT_NE(lease_of(w), held) << "meanwhile B holds it";
    const auto answer = w.finish(master::refused(w.submitted.back().correlation, master::Refusal::BlockUnconfirmed));
    EXPECT_EQ(answer.status, shm::Status::Rejected);
    EXPECT_EQ(lease_of(w), held);
    // A's token works again: its next write renews.
    auto again = write(1, 0xFA01, {1000});
    again.lease_token = a;
    ASSERT_FALSE(w.accept(again, t0 + 60ms).has_value());
    EXPECT_EQ(w.ok(w.submitted.back().correlation).status, shm::Status::Ok);
    EXPECT_EQ(w.leases.status(0).holder_pid, 1);
}

// While a write that renews the lease waits for the wire, the lease does not run out under it
// (whether it was renewed is not known yet); refused, the old deadline holds and the fallback
// follows at once; sent, it was renewed.
TEST(ARefusedRequest, ALeaseWaitsForItsWritesAnswerBeforeRunningOut) {
    for (const bool sent : {false, true}) {
        World w;
        const auto a = w.command(1, t0);  // runs out at t0 + 500 ms
        auto r = write(1, 0xFA01, {1000});
        r.lease_token = a;
        ASSERT_FALSE(w.accept(r, t0 + 400ms).has_value());
        w.expire(t0 + 600ms);
        EXPECT_TRUE(w.fallbacks.empty()) << "ran out while its renewal waited";
        if (sent) {
            w.ok(w.submitted.back().correlation);
        } else {
            (void)w.finish(master::refused(w.submitted.back().correlation, master::Refusal::Expired));
        }
        w.expire(t0 + 650ms);
        EXPECT_EQ(w.fallbacks.size(), sent ? 0U : 1U);
        w.expire(t0 + 950ms);
        EXPECT_EQ(w.fallbacks.size(), 1U) << "renewed at +400 ms: runs out at +900 ms";
    }
}

// The intake logs nothing itself: a rejection is a note for its caller (drivebusd writes it to
// the journal), with the request's client and the reason.
TEST(IntakeNotes, ARejectedRequestIsANoteForTheCaller) {
    const auto bus = pump_bus();
    LeasePolicy leases{bus, [] { return shm::LeaseToken{1, 7}; }};
    std::vector<Note> notes;
    std::size_t submitted = 0;
    IntakeCore intake{bus, leases, [&](const master::ClientRequest&) { return ++submitted, true; },
                      {},  {},     [&](const Note& note) { notes.push_back(note); }};
    Route route = 0;
    const auto answer = intake.accept(write(1, 0x1234, {1}), route, true, t0);
    ASSERT_TRUE(answer.has_value());
    EXPECT_EQ(answer->status, shm::Status::Rejected);
    EXPECT_EQ(submitted, 0U);
    ASSERT_EQ(notes.size(), 1U);
    EXPECT_EQ(notes[0].level, log::Level::Info);
    EXPECT_TRUE(notes[0].text.starts_with("bus line1: request from client-1 rejected: ")) << notes[0].text;

    // An accepted request is no note.
    EXPECT_FALSE(intake.accept(write(2, 0xFA01, {500}), route, true, t0).has_value());
    EXPECT_EQ(submitted, 1U);
    EXPECT_EQ(notes.size(), 1U);
}

}  // namespace
}  // namespace drivebus::ipc
