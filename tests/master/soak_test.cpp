// SPDX-License-Identifier: Apache-2.0
// The truth-checked soak on the virtual line: the real BusEngine against the simulator's drives
// (an Altivar 21 "pump" at address 1, an Altivar 58 "fan" at 2), with wire faults switched at
// random and random client traffic. Every value a client gets and every valid value of every
// snapshot is checked against what the simulated drive held when it answered; every write
// against the drive's own write log. The line's clock jumps from event to event, so 10^5
// transactions take seconds.
//
//   DRIVEBUS_SOAK_TRANSACTIONS=1000000   the long run (the suite runs 100000; a tenth under ASan)
//   DRIVEBUS_SOAK_SEED=N                 replays a run: the seed is in every summary and failure
#include <gtest/gtest.h>

#include <cstdlib>
#include <deque>
#include <iostream>
#include <map>
#include <random>
#include <sstream>

#include "fixtures.hpp"
#include "master/block_setup.hpp"
#include "virtual_line.hpp"

namespace drivebus::test {
namespace {

using namespace std::chrono_literals;
using master::Outcome;

const rtu::Instant kStart{std::chrono::seconds(100)};
constexpr rtu::SlaveAddress kPump = 1;
constexpr rtu::SlaveAddress kFan = 2;

#if defined(__SANITIZE_ADDRESS__)
// The ASan stage builds for debugging and instruments every access: about ten times slower, so
// it runs a tenth of the volume (the same code paths, fewer of them).
constexpr std::uint64_t kSuiteTransactions = 10'000;
#else
constexpr std::uint64_t kSuiteTransactions = 100'000;
#endif

std::uint64_t env_number(const char* name, std::uint64_t fallback) {
    const char* text = std::getenv(name);
    return text == nullptr || *text == '\0' ? fallback : std::strtoull(text, nullptr, 0);
}

using Word = std::pair<std::uint16_t, std::uint16_t>;  // (register, value), as the write log holds them

// A write range a client may use: in the profile's range, and a register drivebusd does not
// set itself (the indirect blocks' selectors) nor one that changes the line (F800-F803, F829).
struct Writable {
    const char* name;
    std::uint16_t min;
    std::uint16_t max;
};
const Writable kPumpWrites[] = {{"FA01", 0, 8000}, {"FA13", 0, 24000}, {"FA20", 0, 65535},
                                {"FA50", 0, 255},  {"FA51", 0, 1023},  {"ACC", 1, 300}};
// The control word takes commands, not numbers: run forward and reverse with Modbus priority,
// stop, fault reset, nothing.
const std::uint16_t kPumpCommands[] = {0xC400, 0xC600, 0xC000, 0xE000, 0x0000};
// What clients read on the pump: the motor's values (they move while it ramps), the written
// registers, the analog inputs the soak changes as an operator would, the fault history.
const char* const kPumpReads[] = {"FD00", "FD01", "FE03", "FE05", "FC91", "FC90", "FE90",
                                  "FE02", "FE15", "FA00", "FA01", "FA13", "FA20", "FA50",
                                  "FA51", "FE35", "FE36", "ACC",  "F803", "FE10", "FE01"};

// How the outcome of a client write bounds the copies of it in the drive's write log. Modbus
// RTU carries no transaction id, so a write whose reply was spoiled is sent again and the drive
// applies it again: a write acknowledged after n attempts is there 1 to n times, back to back
// (the same value written twice in a row, not a reordering). A write whose attempts all failed
// may have been applied by each of them: its outcome is unknown, 0 to n copies. A write refused
// with an exception, or never sent, is not there.
std::pair<unsigned, unsigned> copies_allowed(Outcome outcome, unsigned attempts) {
    switch (outcome) {
    case Outcome::Ok: return {1, std::max(1U, attempts)};
    case Outcome::Exception:
    case Outcome::BusDown:
    case Outcome::Expired: return {0, 0};
    case Outcome::Timeout:
    case Outcome::BadFrame:
    case Outcome::EchoMismatch:
    case Outcome::Late: return {0, attempts};
    }
    return {0, 0};
}

struct DoneWrite {
    std::vector<Word> words;
    Outcome outcome = Outcome::Ok;
    unsigned attempts = 0;
};

// Whether `log` is exactly the writes in `done` (in the order the bus finished them), each
// repeated as its outcome allows; the copies of each, if so.
std::optional<std::vector<unsigned>> explain(const std::vector<Word>& log, const std::vector<DoneWrite>& done,
                                             bool acknowledged_may_be_missing = false) {
    // reach[i][p]: the first i writes can end at log position p, after (previous position, copies).
    using Step = std::optional<std::pair<std::size_t, unsigned>>;
    std::vector<std::vector<Step>> reach(done.size() + 1, std::vector<Step>(log.size() + 1));
    reach[0][0] = std::pair<std::size_t, unsigned>{0, 0};
    for (std::size_t i = 0; i < done.size(); ++i) {
        auto [lo, hi] = copies_allowed(done[i].outcome, done[i].attempts);
        if (acknowledged_may_be_missing) {
            lo = 0;
        }
        const auto& w = done[i].words;
        for (std::size_t start = 0; start <= log.size(); ++start) {
            if (!reach[i][start]) {
                continue;
            }
            std::size_t p = start;
            for (unsigned k = 0; k <= hi; ++k) {
                if (k >= lo && !reach[i + 1][p]) {
                    reach[i + 1][p] = std::pair<std::size_t, unsigned>{start, k};
                }
                if (k == hi || p + w.size() > log.size() ||
                    !std::equal(w.begin(), w.end(), log.begin() + static_cast<std::ptrdiff_t>(p))) {
                    break;
                }
                p += w.size();
            }
        }
    }
    if (!reach.back()[log.size()]) {
        return std::nullopt;
    }
    std::vector<unsigned> copies(done.size());
    std::size_t p = log.size();
    for (std::size_t i = done.size(); i > 0; --i) {
        const auto [previous, k] = *reach[i][p];
        copies[i - 1] = k;
        p = previous;
    }
    return copies;
}

std::string describe(const std::vector<Word>& words) {
    std::ostringstream out;
    for (const auto& [reg, value] : words) {
        out << ' ' << std::hex << "0x" << reg << std::dec << '=' << value;
    }
    return out.str();
}

struct Tally {
    std::uint64_t transactions = 0;
    std::map<Outcome, std::uint64_t> outcomes;
    std::uint64_t values_checked = 0;
    std::uint64_t snapshot_values_checked = 0;
    std::uint64_t snapshots = 0;
    std::uint64_t wrong_values = 0;
    std::uint64_t unverifiable = 0;  // a value older than the history kept: not judged
    std::uint64_t unexpected_exceptions = 0;
    std::uint64_t writes_ok = 0;
    std::uint64_t writes_doubled = 0;          // acknowledged, applied more than once (retried)
    std::uint64_t writes_unknown = 0;          // every attempt failed...
    std::uint64_t writes_unknown_applied = 0;  // ...and the drive had applied it all the same
    std::uint64_t lost_writes = 0;             // batches whose log misses an acknowledged write
    std::uint64_t foreign_writes = 0;          // batches whose log holds a write nobody asked for
    std::uint64_t setup_writes = 0;            // drivebusd's own selector writes, seen in the log
    std::uint64_t fault_switches = 0;
};

class Soak {
public:
    Soak(std::uint64_t seed, bool echo, bool combined, std::string_view kinds)
        : seed_(seed), echo_(echo), combined_(combined), kinds_(kinds), rng_(seed) {
        config_.response_timeout = 100ms;
        config_.retries = 2;
        config_.echo = echo ? master::EchoMode::On : master::EchoMode::Off;
        auto pump = drive("pump", kPump, atv21_);
        pump.polls.push_back(poll(*atv21_, {"FD00", "FD01", "FE03", "FE05", "FC91"}, 100ms, true));
        pump.polls.push_back(poll(*atv21_, {"FA51", "FE35", "FC90"}, 250ms));
        pump.polls.back().name = "slow";
        pump.keep_alive = 1s;
        config_.drives.push_back(pump);
        auto fan = drive("fan", kFan, atv58_);
        fan.polls.push_back(
            poll(*atv58_, {"W450", "W451", "W452", "W453", "W454", "W455", "W456", "W457", "W458", "W459"}, 200ms));
        fan.polls.push_back(poll(*atv58_, {"W400", "W401"}, 300ms));
        fan.polls.back().name = "command";
        config_.drives.push_back(fan);
        for (const auto& w : master::setup_writes(config_.drives[0])) {
            setup_[kPump].push_back(w);
        }

        drives_.add(sim::make_drive(kPump, atv21_));
        drives_.add(sim::make_drive(kFan, atv58_));
        // A pump commissioned before: its block selectors hold what drivebusd wants and are in
        // effect (they apply after a reset; EngineTest covers the first set-up).
        for (const auto& [reg, value] : setup_[kPump]) {
            (void)drives_.drive(kPump)->poke(atv21_->find(reg)->name, value);
        }
        drives_.drive(kPump)->power_cycle(kStart);
        for (const char* name : kPumpReads) {
            track(kPump, name);
        }
        for (const char* name :
             {"W400", "W401", "W450", "W451", "W452", "W453", "W454", "W455", "W456", "W457", "W458", "W459"}) {
            track(kFan, name);
        }
        if (echo) {
            (void)drives_.faults().apply(0, "echo=1");
        }
        poke_inputs();

        master::EngineCallbacks callbacks;
        callbacks.snapshot = [this](const master::DriveSnapshot& s) { check_snapshot(s); };
        callbacks.client_result = [this](std::uint64_t id, const master::Result& r) { on_result(id, r); };
        engine_ = std::make_unique<master::BusEngine>(config_, timing_, callbacks, kStart);
        engine_->line_up(kStart);
        line_ = std::make_unique<VirtualLine>(*engine_, drives_, timing_, kStart);
        line_->set_handled([this](const rtu::Frame& f, rtu::Instant at) { on_handled(f, at); });
        line_->set_recording(false);
        record(kPump, kStart);
        record(kFan, kStart);
    }

    void run(std::uint64_t transactions) {
        while (tally_.transactions < transactions && !::testing::Test::HasFatalFailure()) {
            std::uniform_real_distribution<double> u(0.0, 1.0);
            if (u(rng_) < 0.05) {
                combined_ ? switch_combined() : switch_single();
            }
            if (u(rng_) < 0.3) {
                poke_inputs();
            }
            batch(std::uniform_int_distribution<std::size_t>(1, 24)(rng_));
            check_writes(kPump);
            check_writes(kFan);
            if (u(rng_) < 0.1) {
                // The bus alone for a while: polls and keep-alives under the faults in force.
                line_->run_for(std::chrono::milliseconds(std::uniform_int_distribution<int>(1, 800)(rng_)));
            }
        }
    }

    [[nodiscard]] const Tally& tally() const noexcept { return tally_; }

    [[nodiscard]] std::string summary() const {
        const auto& c = engine_->status().counters;
        const auto o = [&](Outcome k) {
            return tally_.outcomes.contains(k) ? tally_.outcomes.at(k) : std::uint64_t{0};
        };
        std::ostringstream out;
        out << "soak seed=" << seed_ << " echo=" << (echo_ ? "on" : "off") << " transactions=" << tally_.transactions
            << " ok=" << o(Outcome::Ok) << " exception=" << o(Outcome::Exception) << " timeout=" << o(Outcome::Timeout)
            << " late=" << o(Outcome::Late) << " bad_frame=" << o(Outcome::BadFrame)
            << " echo_mismatch=" << o(Outcome::EchoMismatch) << " bus_down=" << o(Outcome::BusDown)
            << " | values_checked=" << tally_.values_checked << " snapshots=" << tally_.snapshots
            << " snapshot_values_checked=" << tally_.snapshot_values_checked << " wrong_values=" << tally_.wrong_values
            << " unverifiable=" << tally_.unverifiable << " unexpected_exceptions=" << tally_.unexpected_exceptions
            << " | writes_ok=" << tally_.writes_ok << " doubled_writes=" << tally_.writes_doubled
            << " unknown_writes=" << tally_.writes_unknown << " (applied " << tally_.writes_unknown_applied
            << ") lost_writes=" << tally_.lost_writes << " foreign_writes=" << tally_.foreign_writes
            << " setup_writes=" << tally_.setup_writes << " | fault_switches=" << tally_.fault_switches
            << " transmissions=" << c.transmissions << " retries=" << c.retries << " timeouts=" << c.timeouts
            << " late_replies=" << c.late_replies << " crc_errors=" << c.crc_errors << " gap_errors=" << c.gap_errors
            << " noise=" << c.noise << " held_replies=" << c.held_replies << " sync_probes=" << c.sync_probes
            << " foreign=" << c.foreign
            << " line_seconds=" << std::chrono::duration<double>(line_->now() - kStart).count();
        return out.str();
    }

private:
    struct Handled {
        rtu::Instant at{};
        rtu::Adu request;
    };
    struct Pending {
        rtu::RequestAdu request;
        bool invalid = false;  // reads a register the drive does not have: an exception is the right answer
    };

    // ---- the truth: what each drive held after each request it handled ----

    void track(rtu::SlaveAddress address, const char* name) {
        const RegisterInfo* info = drives_.drive(address)->profile().find(name);
        ASSERT_TRUE(info != nullptr && info->address.has_value()) << name;
        tracked_[address].emplace_back(*info->address, name);
    }

    // A drive's registers change only when it handles a request (its clock runs then) or when
    // the soak sets one as an operator would: what it holds just after a request is what its
    // reply carries, until the next request it handles.
    void record(rtu::SlaveAddress address, rtu::Instant at) {
        const sim::ProfileDrive* d = drives_.drive(address);
        for (const auto& [reg, name] : tracked_[address]) {
            auto& h = history_[{address, reg}];
            const std::uint16_t v = d->peek(name).value();
            if (h.empty() || h.back().second != v) {
                h.emplace_back(at, v);
            }
            while (h.size() > 1 && h[1].first + 600s < at) {
                h.pop_front();
            }
        }
    }

    void on_handled(const rtu::Frame& frame, rtu::Instant at) {
        const rtu::SlaveAddress address = frame.adu.empty() ? 0 : frame.adu[0];
        if (tracked_.contains(address)) {
            record(address, at);
        }
        ++handled_count_;
        Handled h{at, {}};
        h.request.append(frame.adu.bytes());
        frames_.push_back(h);
        if (frames_.size() > 4096) {
            frames_.pop_front();
        }
    }

    // What `reg` held just after the drive handled a request at `at`.
    std::optional<std::uint16_t> held(rtu::SlaveAddress address, std::uint16_t reg, rtu::Instant at) const {
        const auto it = history_.find({address, reg});
        if (it == history_.end()) {
            return std::nullopt;
        }
        for (auto e = it->second.rbegin(); e != it->second.rend(); ++e) {
            if (e->first <= at) {
                return e->second;
            }
        }
        return std::nullopt;
    }

    // The values a reply accepted at `time` may rightly carry for `reg`: what the drive held
    // when it took one of the transaction's attempts. Every attempt sends the same request, so
    // a reply to any of them answers it (docs/drivebusd.md, "Late replies"); the attempts are
    // the last requests on the line before `time`, one transaction being on the line at a time.
    // `attempts` unknown (a poll's): the identical requests back to back, as many as a
    // transaction can have.
    std::vector<std::uint16_t> rightful(rtu::SlaveAddress address, std::uint16_t reg, rtu::Instant time,
                                        std::optional<unsigned> attempts) const {
        std::vector<std::uint16_t> out;
        auto last = frames_.rbegin();
        while (last != frames_.rend() && last->at > time) {
            ++last;
        }
        const unsigned most = attempts.value_or(config_.retries + 1);
        unsigned n = 0;
        for (auto f = last; f != frames_.rend() && n < most; ++f, ++n) {
            if (!attempts && !std::ranges::equal(f->request.bytes(), last->request.bytes())) {
                break;
            }
            if (f->request.empty() || f->request[0] != address) {
                break;  // not an attempt of this transaction: the check below fails
            }
            if (const auto v = held(address, reg, f->at)) {
                out.push_back(*v);
            }
        }
        return out;
    }

    void check_value(rtu::SlaveAddress address, std::uint16_t reg, std::uint16_t value, rtu::Instant time,
                     const char* what, std::optional<unsigned> attempts = std::nullopt) {
        const auto expected = rightful(address, reg, time, attempts);
        if (expected.empty()) {
            ++tally_.unverifiable;
            return;
        }
        if (std::ranges::find(expected, value) == expected.end()) {
            ++tally_.wrong_values;
            if (tally_.wrong_values <= 10) {
                ADD_FAILURE() << "seed " << seed_ << ": " << what << " of register 0x" << std::hex << reg << std::dec
                              << " on drive " << int(address) << " gave " << value << ", the drive held "
                              << expected.front() << " (line time "
                              << std::chrono::duration<double>(time - kStart).count() << " s)"
                              << "\n faults in force: " << drives_.faults().to_string()
                              << (held_ ? ", deliveries held back" : "") << recent();
            }
        }
    }

    // The last requests on the line, for a failure's message.
    [[nodiscard]] std::string recent() const {
        std::ostringstream out;
        for (std::size_t i = frames_.size() > 12 ? frames_.size() - 12 : 0; i < frames_.size(); ++i) {
            out << "\n  " << std::chrono::duration<double>(frames_[i].at - kStart).count() << " s:" << std::hex;
            for (const auto b : frames_[i].request.bytes()) {
                out << ' ' << static_cast<int>(b);
            }
            out << std::dec;
        }
        return out.str();
    }

    // ---- clients ----

    void batch(std::size_t n) {
        for (std::size_t i = 0; i < n; ++i) {
            const std::uint64_t client = std::uniform_int_distribution<std::uint64_t>(1, 3)(rng_);
            const bool pump = std::bernoulli_distribution(0.5)(rng_);
            const bool write = std::bernoulli_distribution(0.4)(rng_);
            Pending p = pump ? (write ? pump_write() : pump_read()) : (write ? fan_write() : fan_read());
            const std::uint64_t id = ++correlation_;
            auto ok = engine_->submit({client, id, p.request, false});
            ASSERT_TRUE(ok.has_value()) << "seed " << seed_ << ": the engine refused a request";
            pending_.emplace(id, std::move(p));
        }
        ASSERT_TRUE(line_->run_until_true([&] { return pending_.empty(); }, 3600s))
            << "seed " << seed_ << ": " << pending_.size() << " requests never answered";
        // A write answered while still on the wire (its echo differed) reaches the drive after
        // its answer: the write logs are read once the drives have had every request.
        ASSERT_TRUE(
            line_->run_until_true([&] { return handled_count_ == engine_->status().counters.transmissions; }, 10s));
    }

    template <typename T>
    T pick(T lo, T hi) {
        return std::uniform_int_distribution<T>(lo, hi)(rng_);
    }

    Pending pump_read() {
        const auto& list = tracked_.at(kPump);
        const auto& [reg, name] = list[pick<std::size_t>(0, list.size() - 1)];
        return {{kPump, rtu::ReadHoldingRegisters{reg, 1}}, false};
    }

    Pending pump_write() {
        const auto& profile = drives_.drive(kPump)->profile();
        std::uint16_t reg = 0;
        std::uint16_t value = 0;
        if (std::bernoulli_distribution(0.2)(rng_)) {
            reg = *profile.find("FA00")->address;
            value = kPumpCommands[pick<std::size_t>(0, std::size(kPumpCommands) - 1)];
        } else {
            const Writable& w = kPumpWrites[pick<std::size_t>(0, std::size(kPumpWrites) - 1)];
            reg = *profile.find(w.name)->address;
            value = pick<std::uint16_t>(w.min, w.max);
        }
        if (std::bernoulli_distribution(0.5)(rng_)) {
            return {{kPump, rtu::WriteSingleRegister{reg, value}}, false};
        }
        return {{kPump, rtu::WriteMultipleRegisters{reg, rtu::RegisterValues{value}}}, false};
    }

    Pending fan_read() {
        // Now and then a register the drive does not have (402, or 449 at the start of two):
        // the drive answers exception 2, and a value would be wrong.
        if (std::bernoulli_distribution(0.05)(rng_)) {
            return std::bernoulli_distribution(0.5)(rng_) ? Pending{{kFan, rtu::ReadHoldingRegisters{402, 1}}, true}
                                                          : Pending{{kFan, rtu::ReadHoldingRegisters{449, 2}}, true};
        }
        if (std::bernoulli_distribution(0.25)(rng_)) {
            const auto start = pick<std::uint16_t>(400, 401);
            return {{kFan, rtu::ReadHoldingRegisters{start, pick<std::uint16_t>(1, 402 - start)}}, false};
        }
        const auto start = pick<std::uint16_t>(450, 459);
        return {{kFan, rtu::ReadHoldingRegisters{start, pick<std::uint16_t>(1, 460 - start)}}, false};
    }

    Pending fan_write() {
        switch (pick(0, 2)) {
        case 0: return {{kFan, rtu::WriteSingleRegister{pick<std::uint16_t>(400, 401), pick<std::uint16_t>(0, 65535)}}};
        case 1:
            return {{kFan, rtu::WriteMultipleRegisters{400, rtu::RegisterValues{pick<std::uint16_t>(0, 65535),
                                                                                pick<std::uint16_t>(0, 65535)}}}};
        default:
            return {{kFan, rtu::WriteMultipleRegisters{pick<std::uint16_t>(400, 401),
                                                       rtu::RegisterValues{pick<std::uint16_t>(0, 65535)}}}};
        }
    }

    void on_result(std::uint64_t id, const master::Result& r) {
        const auto it = pending_.find(id);
        ASSERT_NE(it, pending_.end()) << "seed " << seed_ << ": a result for request " << id << ", answered twice?";
        const Pending p = std::move(it->second);
        pending_.erase(it);
        ++tally_.transactions;
        ++tally_.outcomes[r.outcome];
        const rtu::SlaveAddress address = p.request.address;
        if (const auto* read = std::get_if<rtu::ReadHoldingRegisters>(&p.request.pdu)) {
            check_read(address, *read, p.invalid, r);
            return;
        }
        if (r.outcome == Outcome::Exception) {
            note_unexpected_exception(address, r);
        }
        DoneWrite done{{}, r.outcome, r.attempts};
        if (const auto* one = std::get_if<rtu::WriteSingleRegister>(&p.request.pdu)) {
            done.words.emplace_back(one->address, one->value);
            if (r.outcome == Outcome::Ok && std::get_if<rtu::WriteSingleRegisterResponse>(&*r.response) == nullptr) {
                wrong_reply(address, "FC06");
            } else if (r.outcome == Outcome::Ok) {
                const auto& echo = std::get<rtu::WriteSingleRegisterResponse>(*r.response);
                if (echo.address != one->address || echo.value != one->value) {
                    wrong_reply(address, "FC06");
                }
            }
        } else {
            const auto& many = std::get<rtu::WriteMultipleRegisters>(p.request.pdu);
            for (std::size_t i = 0; i < many.values.size(); ++i) {
                done.words.emplace_back(static_cast<std::uint16_t>(many.start + i), many.values[i]);
            }
            if (r.outcome == Outcome::Ok) {
                const auto* echo = std::get_if<rtu::WriteMultipleRegistersResponse>(&*r.response);
                if (echo == nullptr || echo->start != many.start || echo->quantity != many.values.size()) {
                    wrong_reply(address, "FC16");
                }
            }
        }
        done_[address].push_back(std::move(done));
    }

    void wrong_reply(rtu::SlaveAddress address, const char* function) {
        ++tally_.wrong_values;
        ADD_FAILURE() << "seed " << seed_ << ": drive " << int(address) << ": the " << function
                      << " reply accepted does not answer its request";
    }

    void note_unexpected_exception(rtu::SlaveAddress address, const master::Result& r) {
        ++tally_.unexpected_exceptions;
        if (tally_.unexpected_exceptions <= 10) {
            ADD_FAILURE() << "seed " << seed_ << ": drive " << int(address)
                          << " answered a valid request with exception "
                          << static_cast<int>(r.exception().value_or(rtu::ExceptionCode{0}));
        }
    }

    void check_read(rtu::SlaveAddress address, const rtu::ReadHoldingRegisters& read, bool invalid,
                    const master::Result& r) {
        if (r.outcome == Outcome::Exception) {
            if (!invalid || r.exception() != rtu::ExceptionCode::IllegalDataAddress) {
                note_unexpected_exception(address, r);
            }
            return;
        }
        if (r.outcome != Outcome::Ok) {
            return;
        }
        const auto* words = std::get_if<rtu::ReadHoldingRegistersResponse>(&*r.response);
        if (invalid || words == nullptr || words->values.size() != read.quantity) {
            wrong_reply(address, "FC03");
            return;
        }
        for (std::uint16_t i = 0; i < read.quantity; ++i) {
            ++tally_.values_checked;
            check_value(address, static_cast<std::uint16_t>(read.start + i), words->values[i], r.finished,
                        "a client read", r.attempts);
        }
    }

    void check_snapshot(const master::DriveSnapshot& s) {
        ++tally_.snapshots;
        for (const auto& [reg, v] : s.registers) {
            if (v.valid) {
                ++tally_.snapshot_values_checked;
                check_value(s.address, reg, v.value, v.time, "a snapshot");
            }
        }
    }

    // ---- writes against the drive's log ----

    void check_writes(rtu::SlaveAddress address) {
        const sim::ProfileDrive* d = drives_.drive(address);
        const std::uint64_t total = d->writes_accepted();
        const auto fresh = static_cast<std::size_t>(total - logged_[address]);
        logged_[address] = total;
        const auto& log = d->write_log();
        ASSERT_LE(fresh, log.size()) << "a batch wrote more than the simulator's write log keeps";
        std::vector<Word> words;
        const auto& setup = setup_[address];
        for (auto it = log.end() - static_cast<std::ptrdiff_t>(fresh); it != log.end(); ++it) {
            if (std::ranges::find(setup, *it) != setup.end()) {
                ++tally_.setup_writes;  // drivebusd's own, when the drive comes (back) online
                continue;
            }
            words.push_back(*it);
        }
        std::vector<DoneWrite> done = std::move(done_[address]);
        done_[address].clear();
        if (const auto copies = explain(words, done)) {
            for (std::size_t i = 0; i < done.size(); ++i) {
                if (done[i].outcome == Outcome::Ok) {
                    ++tally_.writes_ok;
                    tally_.writes_doubled += (*copies)[i] > 1 ? 1U : 0U;
                } else if (done[i].outcome != Outcome::Exception && done[i].outcome != Outcome::BusDown) {
                    ++tally_.writes_unknown;
                    tally_.writes_unknown_applied += (*copies)[i] > 0 ? 1U : 0U;
                }
            }
            return;
        }
        const bool lost = explain(words, done, true).has_value();
        ++(lost ? tally_.lost_writes : tally_.foreign_writes);
        std::ostringstream asked;
        for (const auto& w : done) {
            asked << "\n  " << master::to_string(w.outcome) << " after " << w.attempts
                  << " attempt(s):" << describe(w.words);
        }
        ADD_FAILURE() << "seed " << seed_ << ": drive " << int(address) << "'s write log does not match the writes ("
                      << (lost ? "an acknowledged write is missing" : "a write nobody asked for, or out of order")
                      << ")\n log:" << describe(words) << "\n writes, in the order they finished:" << asked.str();
    }

    // ---- faults and the process around the drives ----

    static constexpr const char* kKinds[] = {"crc", "drop", "late", "gap", "noise"};

    // DRIVEBUS_SOAK_FAULTS (say "crc,late,held") narrows the faults to those kinds, to tell
    // which one a failure needs; by default the test's own list, or every kind, and deliveries
    // held back ("held").
    [[nodiscard]] bool enabled(std::string_view kind) const {
        const char* env = std::getenv("DRIVEBUS_SOAK_FAULTS");
        std::string_view list = env != nullptr && *env != '\0' ? std::string_view(env) : kinds_;
        if (list.empty()) {
            return true;
        }
        while (!list.empty()) {
            const auto comma = list.find(',');
            if (list.substr(0, comma) == kind) {
                return true;
            }
            list = comma == std::string_view::npos ? std::string_view{} : list.substr(comma + 1);
        }
        return false;
    }

    // One kind of fault at a time, on one drive or on the line: what the suite runs.
    void switch_single() {
        ++tally_.fault_switches;
        drives_.faults().clear(kPump);
        drives_.faults().clear(kFan);
        set_delivery(false);
        const int kind = pick(0, 6);  // none, the five wire faults, deliveries held back
        if (kind == 0) {
            return;
        }
        if (kind == 6) {
            set_delivery(enabled("held"));
            return;
        }
        add_fault(pick(0, 1) == 0 ? kPump : kFan, kind - 1);
    }

    // Faults of every kind together, on both drives, deliveries held back or not, and noise and
    // gaps that spoil a reply: EngineSoak.CombinedFaults (the defects it found are named there).
    void switch_combined() {
        ++tally_.fault_switches;
        std::uniform_real_distribution<double> u(0.0, 1.0);
        for (const rtu::SlaveAddress address : {kPump, kFan}) {
            drives_.faults().clear(address);
            const int count = u(rng_) < 0.3 ? 0 : (u(rng_) < 0.8 ? 1 : 2);
            for (int i = 0; i < count; ++i) {
                add_fault(address, pick(0, 4));
            }
        }
        if (u(rng_) < 0.4) {
            set_delivery(u(rng_) < 0.5 && enabled("held"));
        }
    }

    void add_fault(rtu::SlaveAddress address, int kind) {
        if (!enabled(kKinds[kind])) {
            return;
        }
        std::uniform_real_distribution<double> u(0.0, 1.0);
        std::ostringstream f;
        switch (kind) {
        case 0: f << "crc=" << pick(1, 10) / 10.0; break;
        case 1: f << "drop=" << pick(1, 10) / 10.0; break;
        case 2: {
            // 0.5 to 2.5 times the response time-out: before it, around it and well after.
            const auto late =
                std::chrono::duration_cast<std::chrono::microseconds>(config_.response_timeout * (0.5 + 2.0 * u(rng_)));
            f << "late=" << late.count() << "us";
            break;
        }
        case 3: {
            // A silence inside the reply: within its wire bound, or within the delivery
            // allowance; combined, also past both (100 and 300 characters: 52 and 156 ms at
            // 19200 bit/s), which spoils the reply.
            static constexpr double kChars[] = {1.0, 2.0, 3.0, 5.0, 20.0, 100.0, 300.0};
            f << "gap=" << pick(1, 8) << ':' << kChars[pick<std::size_t>(0, std::size(kChars) - (combined_ ? 1 : 3))];
            break;
        }
        default: {
            // Noise before the reply: 1 to 3 bytes, too short to be a frame; combined, up to 6,
            // as long as a reply.
            static constexpr double kSilence[] = {0.5, 1.0, 2.0, 3.0, 4.0, 10.0};
            f << "noise=" << pick(1, combined_ ? 6 : 3) << ':'
              << kSilence[pick<std::size_t>(0, std::size(kSilence) - 1)];
            break;
        }
        }
        const auto ok = drives_.faults().apply(address, f.str());
        ASSERT_TRUE(ok.has_value()) << f.str() << ": " << ok.error();
    }

    // The kernel's tty worker holding back now and then the rest of what it received, by up
    // to 40 ms (within the 50 ms delivery allowance), or handing everything over on time.
    void set_delivery(bool held) {
        held_ = held;
        if (!held) {
            line_->set_delivery(nullptr);
            return;
        }
        const std::uint64_t salt = rng_();
        line_->set_delivery([salt](std::size_t reply, std::size_t index, rtu::Instant at) {
            std::uint64_t x = salt ^ (reply * 0x9E3779B97F4A7C15ULL) ^ (index + 1) * 0xBF58476D1CE4E5B9ULL;
            x ^= x >> 31;
            x *= 0x94D049BB133111EBULL;
            x ^= x >> 29;
            if (x % 8 != 0) {
                return at;
            }
            return at + std::chrono::microseconds((x >> 8) % 40'000);
        });
    }

    // The analog inputs and the ATV58's supervision words change as the process runs.
    void poke_inputs() {
        auto* pump = drives_.drive(kPump);
        (void)pump->poke("FE35", pick<std::uint16_t>(0, 1023));
        (void)pump->poke("FE36", pick<std::uint16_t>(0, 1023));
        auto* fan = drives_.drive(kFan);
        for (int i = 0; i < 10; ++i) {
            if (std::bernoulli_distribution(0.5)(rng_)) {
                (void)fan->poke("W45" + std::to_string(i), pick<std::uint16_t>(0, 65535));
            }
        }
    }

    std::uint64_t seed_;
    bool echo_;
    bool combined_;
    std::string_view kinds_;
    std::mt19937_64 rng_;
    std::shared_ptr<const Profile> atv21_ = load("atv21");
    std::shared_ptr<const Profile> atv58_ = load("atv58");
    master::BusPlan config_ = bus();
    rtu::CharacterTiming timing_ = rtu::character_timing(config_.format).value();
    sim::Bus drives_{{timing_, 1ms, true, static_cast<std::uint32_t>(seed_)}};
    std::unique_ptr<master::BusEngine> engine_;
    std::unique_ptr<VirtualLine> line_;

    std::map<rtu::SlaveAddress, std::vector<std::pair<std::uint16_t, std::string>>> tracked_;
    std::map<std::pair<rtu::SlaveAddress, std::uint16_t>, std::deque<std::pair<rtu::Instant, std::uint16_t>>> history_;
    std::map<rtu::SlaveAddress, std::vector<Word>> setup_;
    std::deque<Handled> frames_;  // the last requests the drives handled, oldest first
    std::map<std::uint64_t, Pending> pending_;
    std::map<rtu::SlaveAddress, std::vector<DoneWrite>> done_;
    std::map<rtu::SlaveAddress, std::uint64_t> logged_;
    std::uint64_t correlation_ = 0;
    std::uint64_t handled_count_ = 0;
    bool held_ = false;
    Tally tally_;
};

void soak(bool echo, double share, bool combined = false, std::string_view kinds = {},
          std::optional<std::uint64_t> seed_default = std::nullopt) {
    const std::uint64_t seed = env_number("DRIVEBUS_SOAK_SEED", seed_default.value_or(std::random_device{}()));
    const auto transactions = static_cast<std::uint64_t>(
        static_cast<double>(env_number("DRIVEBUS_SOAK_TRANSACTIONS", kSuiteTransactions)) * share);
    SCOPED_TRACE("DRIVEBUS_SOAK_SEED=" + std::to_string(seed));
    Soak s(seed, echo, combined, kinds);
    s.run(transactions);
    std::cout << s.summary() << std::endl;
    const Tally& t = s.tally();
    EXPECT_GE(t.transactions, transactions);
    EXPECT_EQ(t.wrong_values, 0U);
    EXPECT_EQ(t.unexpected_exceptions, 0U);
    EXPECT_EQ(t.lost_writes, 0U);
    EXPECT_EQ(t.foreign_writes, 0U);
    EXPECT_EQ(t.unverifiable, 0U);
    // The soak saw what it is for: faults of every kind, and values and writes to judge.
    EXPECT_GT(t.values_checked, transactions / 4);
    EXPECT_GT(t.snapshot_values_checked, 0U);
    EXPECT_GT(t.writes_ok, 0U);
    EXPECT_GT(t.fault_switches, 0U);
}

// Most of the volume on a line without echo; a share on a 2-wire adapter that echoes every
// byte the master sends (echo = "on").
TEST(EngineSoak, NoWrongValueNoLostWrite) {
    soak(false, 0.8);
}

TEST(EngineSoak, NoWrongValueNoLostWriteWithEcho) {
    soak(true, 0.2);
}

// Late replies, CRC errors, drops and deliveries held back, several at once on both drives
// (found with this mix: a transaction that ended on a spoiled frame after a time-out left no
// quiet time, and the last attempt's late reply was taken by the next request).
TEST(EngineSoak, NoWrongValueUnderLateCrcDropAndHeldTogether) {
    soak(false, 0.2, true, "late,crc,drop,held");
}

// Faults of several kinds at once on both drives, noise as long as a reply, silences that cut
// a reply past the delivery allowance, deliveries held back on top, and replies up to 2.5 x the
// time-out late on both drives. It found wrong values (seed 1: 708 of 316787 checked, in 80000
// transactions) while a spoiled frame failed the attempt at once:
//  - A spoiled frame that is not the attempt's reply (noise of 4 or more bytes in front of it,
//    or the cut-off tail of an earlier reply): the retry went out while the real reply was
//    still coming, took it (the same request: a right answer), and the retry's own reply then
//    landed in the next request's wait.
//  - Noise in front of a reply whose rest the kernel holds back: the frame does not begin with
//    the slave's address, so the reply's wire bound and the delivery allowance did not keep the
//    line busy, and the held rest was taken for the next request's reply.
// A spoiled attempt now waits out its time-out and the guard (Transaction::on_bad_frame()).
TEST(EngineSoak, CombinedFaults) {
    soak(false, 0.8, true);
}

}  // namespace
}  // namespace drivebus::test
