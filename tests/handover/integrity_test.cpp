// SPDX-License-Identifier: Apache-2.0
// A property test of the daemon's control integrity: random sequences of client requests (any
// register, any block, any selector value, several clients honest and not, leases taken, taken
// over, renewed, released and lost to a hung client; the drive switched off and on now and then)
// go through the intake's decisions
// (admission, the lease policy, the pending book), the bus thread's desk and the bus engine,
// onto a virtual line with the simulated drives. No RouDi and no threads: one clock, so every
// run of a seed is the same. Two properties are checked against the simulator's own truth:
//
// - every value published in a snapshot, and every value a client read, is what the drive held
//   for that register when it handled the request (never another register's value, whatever
//   the clients wrote to the block selectors or through the blocks);
// - every frequency reference the drive accepted (FA01, alone or through the write block) came
//   from a client that held the control lease by an independent model of the lease: it took
//   the lease while free, took it over, or presented the current holder's token before it ran
//   out. Each write carries a reference value of its own, so the drive's write log says whose
//   it was. The selectors drivebusd set up are never written by anyone.
#include <gtest/gtest.h>

#include <deque>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "bus.hpp"
#include "bus/desk.hpp"
#include "bus/handover.hpp"
#include "fixtures.hpp"
#include "ipc/intake_core.hpp"
#include "master/block_setup.hpp"
#include "virtual_line.hpp"

namespace drivebus::test {
namespace {

using namespace std::chrono_literals;
using Route = ipc::RouteId;

const rtu::Instant kStart{std::chrono::seconds(1000)};
constexpr rtu::Duration kLease = 300ms;
constexpr rtu::Duration kLeaseMargin = 2ms;  // accept times this close to a deadline prove nothing

enum class Role : std::uint8_t { Honest, Impostor, Reader };

struct Client {
    std::uint64_t id = 0;
    std::string name;
    std::int32_t pid = 0;
    Role role = Role::Reader;
    shm::LeaseToken token{};
    bool waiting = false;       // one request at a time, as libdrivebus's calls are
    rtu::Instant hung_until{};  // an honest client whose control loop blocks: no request at all
};

enum class Verdict : std::uint8_t { None, Valid, Invalid, Uncertain };

// One request as sent, and what came of it.
struct Sent {
    std::size_t client = 0;
    shm::Request request;
    rtu::Instant accepted{};
    bool answered = false;
    shm::Response response{};
    std::optional<std::uint16_t> reference;  // the FA01 value it would write
    bool command = false;                    // it writes FA00 or FA01 (directly or through the block)
    Verdict verdict = Verdict::None;         // by the model: may it change FA00/FA01?
};

class Integrity {
public:
    explicit Integrity(std::uint64_t seed) : seed_(seed), rng_(seed) {
        config_.response_timeout = 100ms;
        config_.retries = 2;
        auto pump = drive("pump", 1, atv21_);
        pump.polls.push_back(poll(*atv21_, {"FD00", "FD01", "FE03", "FE05", "FC91"}, 100ms, true));
        pump.polls.push_back(poll(*atv21_, {"FA00", "FA01", "FC90"}, 200ms));
        pump.polls.back().name = "control";
        pump.write_block = {0xFA00, 0xFA01};
        pump.keep_alive = 1s;
        pump.lease = kLease;
        pump.fallback = config::LeaseFallback::Stop;
        config_.drives.push_back(pump);
        auto fan = drive("fan", 2, atv58_);
        fan.polls.push_back(poll(*atv58_, {"W450", "W451", "W452", "W453"}, 200ms));
        config_.drives.push_back(fan);

        drives_.add(sim::make_drive(1, atv21_));
        drives_.add(sim::make_drive(2, atv58_));
        // A pump commissioned before: the selectors drivebusd wants hold and are in effect.
        for (const auto& [reg, value] : master::setup_writes(config_.drives[0])) {
            (void)drives_.drive(1)->poke(atv21_->find(reg)->name, value);
            selectors_.emplace(reg, value);
        }
        drives_.drive(1)->power_cycle(kStart);
        (void)drives_.drive(1)->poke("F803", 0);  // no Modbus time-out trip while clients idle
        for (int i = 0; i < 4; ++i) {
            (void)drives_.drive(2)->poke("W45" + std::to_string(i), static_cast<std::uint16_t>(1000 + 111 * i));
        }

        handover_ = std::make_unique<bus::Handover>(config_.queue_limit, config_.drives.size());
        desk_ = std::make_unique<bus::Desk>(config_, *handover_);
        engine_ = std::make_unique<master::BusEngine>(config_, timing_, desk_->callbacks({}), kStart);
        desk_->attach(*engine_);
        engine_->line_up(kStart);
        line_ = std::make_unique<VirtualLine>(*engine_, drives_, timing_, kStart);
        line_->set_recording(false);
        line_->set_handled([this](const rtu::Frame& f, rtu::Instant at) { record(f, at); });
        leases_ = std::make_unique<ipc::LeasePolicy>(config_, [this] { return shm::LeaseToken{rng_(), rng_() | 1U}; });
        intake_ = std::make_unique<ipc::IntakeCore>(
            config_, *leases_, [this](const master::ClientRequest& r) { return handover_->requests.try_push(r); });

        const std::vector<Role> roles{Role::Honest, Role::Honest, Role::Impostor, Role::Impostor, Role::Reader};
        for (std::size_t i = 0; i < roles.size(); ++i) {
            clients_.push_back(
                {0x1000 + i, "client" + std::to_string(i), static_cast<std::int32_t>(4000 + i), roles[i]});
        }
    }

    void run(std::size_t steps) {
        for (std::size_t step = 0; step < steps && !::testing::Test::HasFatalFailure(); ++step) {
            const rtu::Instant now = line_->now();
            // What the ipc thread's timer does: leases that ran out get their fallback.
            for (const auto& f : leases_->expire(now)) {
                if (f.write && !intake_->submit_own(f.drive, *f.write)) {
                    (void)leases_->fallback_done(f.drive, master::Outcome::BusDown, true);
                }
            }
            // Now and then the pump is switched off (silent) and on again: drivebusd finds it
            // absent, then sets it up and confirms its block again while the clients go on.
            if (!off_until_ && chance(0.004)) {
                ASSERT_TRUE(drives_.faults().apply(1, "drop=1").has_value());
                off_until_ = now + std::chrono::milliseconds(pick(300, 1500));
            } else if (off_until_ && now >= *off_until_) {
                drives_.drive(1)->power_cycle(now);
                (void)drives_.drive(1)->poke("F803", 0);
                drives_.faults().clear(1);
                off_until_.reset();
                ++power_cycles_;
            }
            for (std::size_t c = 0; c < clients_.size(); ++c) {
                if (!clients_[c].waiting && now >= clients_[c].hung_until && chance(0.5)) {
                    act(c, now);
                }
            }
            desk_->take_requests();
            desk_->retry_fallbacks(now);
            line_->run_for(std::chrono::milliseconds(pick(1, 30)));
            collect();
        }
        // The pump back on, and every request in flight answered (a request to a silent
        // drive takes its time-out and retries: they wait their turn).
        if (off_until_) {
            drives_.drive(1)->power_cycle(line_->now());
            drives_.faults().clear(1);
            off_until_.reset();
        }
        const rtu::Instant deadline = line_->now() + 60s;
        while (std::ranges::any_of(clients_, &Client::waiting) && line_->now() < deadline) {
            desk_->take_requests();
            desk_->retry_fallbacks(line_->now());
            line_->run_for(50ms);
            collect();
        }
    }

    // The checks that need the whole run: the lease model, then the drive's write log.
    void check_leases() {
        model_leases();
        const auto& log = drives_.drive(1)->write_log();
        ASSERT_LT(drives_.drive(1)->writes_accepted(), 1024U) << "the write log no longer holds every write";
        for (const auto& [reg, value] : log) {
            ASSERT_FALSE(selectors_.contains(reg)) << "seed " << seed_ << ": selector 0x" << std::hex << reg
                                                   << " was written (" << std::dec << value << ")";
            if (reg != 0xFA01 && reg != 0x1871) {
                continue;
            }
            const auto it = by_reference_.find(value);
            ASSERT_NE(it, by_reference_.end()) << "seed " << seed_ << ": FA01 = " << value << " came from nobody";
            const Sent& s = sent_[it->second];
            ++references_landed_;
            EXPECT_NE(s.verdict, Verdict::Invalid)
                << "seed " << seed_ << ": " << clients_[s.client].name << "'s FA01 = " << value
                << " reached the drive while it did not hold the lease (answer " << int(s.response.status) << ")";
        }
    }

    [[nodiscard]] std::string summary() const {
        std::map<Verdict, std::size_t> verdicts;
        for (const auto& s : sent_) {
            ++verdicts[s.verdict];
        }
        return "seed " + std::to_string(seed_) + ": " + std::to_string(sent_.size()) + " requests, " +
               std::to_string(snapshot_values_) + " snapshot values and " + std::to_string(read_values_) +
               " read values checked (" + std::to_string(unverifiable_) + " unverifiable), " +
               std::to_string(references_landed_) + " references landed; commands valid " +
               std::to_string(verdicts[Verdict::Valid]) + ", invalid " + std::to_string(verdicts[Verdict::Invalid]) +
               ", uncertain " + std::to_string(verdicts[Verdict::Uncertain]) + "; grants " + std::to_string(grants_) +
               ", expiries " + std::to_string(leases_->expiries()) + ", power cycles " + std::to_string(power_cycles_);
    }

    [[nodiscard]] std::size_t snapshot_values() const noexcept { return snapshot_values_; }
    [[nodiscard]] std::size_t read_values() const noexcept { return read_values_; }
    [[nodiscard]] std::size_t references_landed() const noexcept { return references_landed_; }
    [[nodiscard]] std::size_t invalid_commands() const {
        return static_cast<std::size_t>(std::ranges::count(sent_, Verdict::Invalid, &Sent::verdict));
    }
    [[nodiscard]] std::uint64_t expiries() const { return leases_->expiries(); }
    [[nodiscard]] std::size_t power_cycles() const noexcept { return power_cycles_; }

private:
    bool chance(double p) { return std::uniform_real_distribution<double>(0.0, 1.0)(rng_) < p; }
    int pick(int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng_); }
    std::uint16_t next_reference() {
        // Unique per write, inside FA01's range (0 to FH, 80.00 Hz).
        ++reference_;
        return static_cast<std::uint16_t>(1 + reference_ % 7999);
    }

    shm::Request request(Client& c, shm::RequestKind kind, std::string_view drive_name) {
        shm::Request r;
        r.size = sizeof r;
        r.kind = kind;
        r.client = c.id;
        r.correlation = ++correlation_;
        r.pid = c.pid;
        shm::assign(r.client_name, c.name);
        shm::assign(r.drive, drive_name);
        return r;
    }

    // A register of either drive's profile, a block, or an address no profile has.
    void any_read(shm::Request& r) {
        const int what = pick(0, 9);
        if (what < 2) {
            r.start = 0x1875;  // the read block, any count (2-5 is in range)
            r.count = static_cast<std::uint16_t>(pick(0, 7));
            return;
        }
        const Profile& p = std::string_view(r.drive.data()) == "pump" ? *atv21_ : *atv58_;
        if (what < 9) {
            const auto& reg = p.registers[static_cast<std::size_t>(pick(0, static_cast<int>(p.registers.size()) - 1))];
            r.start = reg.address.value_or(0);
            r.count = static_cast<std::uint16_t>(chance(0.9) ? 1 : pick(0, 4));
            return;
        }
        r.start = static_cast<std::uint16_t>(pick(0, 0xFFFF));
        r.count = 1;
    }

    void act(std::size_t index, rtu::Instant now) {
        Client& c = clients_[index];
        const bool on_pump = chance(0.85);
        auto r = request(c, shm::RequestKind::Read, on_pump ? "pump" : "fan");
        std::optional<std::uint16_t> reference;
        if (c.role == Role::Reader || chance(0.2)) {
            any_read(r);
        } else if (c.role == Role::Honest) {
            const int what = pick(0, 99);
            shm::assign(r.drive, "pump");
            r.lease_token = c.token;
            if (what < 40) {
                reference = next_reference();
                r.kind = shm::RequestKind::Write;
                r.start = 0xFA01;
                r.count = 1;
                r.values[0] = *reference;
                r.function = chance(0.5) ? 6 : 16;
            } else if (what < 55) {
                reference = next_reference();
                r.kind = shm::RequestKind::Write;
                r.start = 0x1870;
                r.count = 2;
                r.values[0] = 0xC400;
                r.values[1] = *reference;
            } else if (what < 65) {
                reference = next_reference();
                r.kind = shm::RequestKind::Write;
                r.start = 0xFA01;
                r.count = 1;
                r.values[0] = *reference;
                r.flags = shm::kFlagTakeOver;
            } else if (what < 80) {
                r.kind = shm::RequestKind::LeaseRenew;
            } else if (what < 85) {
                r.kind = shm::RequestKind::LeaseRelease;
            } else if (what < 90) {
                c.hung_until = now + std::chrono::milliseconds(pick(350, 900));
                return;
            } else {
                any_read(r);
            }
        } else {
            // An impostor: never takes over, but copies the honest clients' ids, names and
            // pids, forges tokens, rewrites selectors, and writes through the blocks.
            shm::assign(r.drive, "pump");
            const Client& victim = clients_[static_cast<std::size_t>(pick(0, 1))];
            switch (pick(0, 3)) {
            case 0: break;
            case 1:
                r.client = victim.id;
                shm::assign(r.client_name, victim.name);
                r.pid = victim.pid;
                break;
            case 2: r.lease_token = shm::LeaseToken{rng_(), rng_()}; break;
            default: r.lease_token = shm::LeaseToken{victim.token[0], victim.token[1] ^ 1U}; break;
            }
            r.kind = shm::RequestKind::Write;
            const int what = pick(0, 99);
            if (what < 30) {
                reference = next_reference();
                r.start = 0xFA01;
                r.count = 1;
                r.values[0] = *reference;
            } else if (what < 50) {
                reference = next_reference();
                r.start = 0x1870;
                r.count = 2;
                r.values[0] = 0xC600;
                r.values[1] = *reference;
            } else if (what < 60) {
                r.start = 0xFA00;
                r.count = 1;
                r.values[0] = 0xC600;
            } else if (what < 85) {
                // Any selector, any value.
                const auto& [reg, value] =
                    *std::next(selectors_.begin(), pick(0, static_cast<int>(selectors_.size()) - 1));
                r.start = reg;
                r.count = 1;
                r.values[0] = static_cast<std::uint16_t>(chance(0.5) ? pick(0, 12) : value);
            } else {
                r.start = static_cast<std::uint16_t>(chance(0.5) ? 0x1870 : pick(0x0860, 0x0880));
                r.count = static_cast<std::uint16_t>(pick(1, 3));
                for (std::size_t i = 0; i < r.count; ++i) {
                    r.values[i] = static_cast<std::uint16_t>(pick(0, 0xFFFF));
                }
                if (r.start == 0x1870 && r.count == 2) {
                    reference = next_reference();  // any command word, and a reference of its own
                    r.values[1] = *reference;
                }
            }
        }
        Sent s;
        s.client = index;
        s.request = r;
        s.accepted = now;
        s.reference = reference;
        s.command = reference.has_value() || (r.kind == shm::RequestKind::Write && r.start == 0xFA00);
        const Route route = sent_.size();
        sent_.push_back(s);
        if (reference) {
            by_reference_[*reference] = route;
        }
        c.waiting = true;
        if (auto answer = intake_->accept(r, route, engine_->up(), now)) {
            deliver(route, *answer);
        }
    }

    void deliver(Route route, const shm::Response& response) {
        Sent& s = sent_.at(route);
        ASSERT_FALSE(s.answered) << "seed " << seed_ << ": a request answered twice";
        s.answered = true;
        s.response = response;
        Client& c = clients_[s.client];
        c.waiting = false;
        if (response.lease_token != shm::LeaseToken{}) {
            c.token = response.lease_token;
        }
        if (s.request.kind == shm::RequestKind::LeaseRelease && response.status == shm::Status::Ok) {
            c.token = {};
        }
    }

    // The bus's results become answers; client reads are checked against the drive's truth.
    void collect() {
        master::Finished f;
        while (handover_->results.try_pop(f)) {
            auto a = intake_->finish(f);
            if (!a || !a->entry.route) {
                continue;
            }
            const Route route = *a->entry.route;
            check_read(sent_.at(route), f);
            deliver(route, a->response);
        }
        master::DriveSnapshot snap;
        while (handover_->snapshots.try_pop(snap)) {
            for (const auto& [reg, v] : snap.registers) {
                if (v.valid) {
                    ++snapshot_values_;
                    check_value(snap.address, reg, v.value, v.time, "a snapshot");
                }
            }
        }
    }

    void check_read(const Sent& s, const master::Finished& f) {
        if (s.request.kind != shm::RequestKind::Read || f.outcome != master::Outcome::Ok ||
            f.refusal != master::Refusal::None) {
            return;
        }
        const rtu::SlaveAddress address = std::string_view(s.request.drive.data()) == "pump" ? 1 : 2;
        const std::vector<std::uint16_t> block{0xFD00, 0xFD01, 0xFE03, 0xFE05, 0xFC91};
        for (std::size_t i = 0; i < f.words.size(); ++i) {
            const std::uint16_t reg = address == 1 && s.request.start == 0x1875
                                          ? block.at(i)
                                          : static_cast<std::uint16_t>(s.request.start + i);
            ++read_values_;
            check_value(address, reg, f.words[i], f.finished, "a client's read");
        }
    }

    // A drive's registers change only when it handles a request: what it holds just after
    // handling one is what its reply carries.
    void record(const rtu::Frame& frame, rtu::Instant at) {
        const rtu::SlaveAddress address = frame.adu.empty() ? 0 : frame.adu[0];
        const sim::ProfileDrive* d = drives_.drive(address);
        if (d == nullptr) {
            return;
        }
        std::map<std::uint16_t, std::uint16_t> values;
        for (const auto& reg : d->profile().registers) {
            if (reg.address) {
                values[*reg.address] = d->peek(reg.name).value();
            }
        }
        auto& h = history_[address];
        h.push_back({at, std::move(values)});
        if (h.size() > 512) {
            h.pop_front();
        }
    }

    // The reply that ended at `time` answered one of the last requests the drive handled
    // before it (an attempt and its retries): the value must be what the drive held then.
    void check_value(rtu::SlaveAddress address, std::uint16_t reg, std::uint16_t value, rtu::Instant time,
                     const char* what) {
        const auto& h = history_[address];
        std::vector<std::uint16_t> rightful;
        for (auto e = h.rbegin(); e != h.rend() && rightful.size() < 3; ++e) {
            if (e->at <= time) {
                const auto v = e->values.find(reg);
                if (v != e->values.end()) {
                    rightful.push_back(v->second);
                }
            }
        }
        if (rightful.empty()) {
            ++unverifiable_;
            return;
        }
        EXPECT_NE(std::ranges::find(rightful, value), rightful.end())
            << "seed " << seed_ << ": " << what << " gave register 0x" << std::hex << reg << std::dec << " of drive "
            << int(address) << " = " << value << ", the drive held " << rightful.front();
    }

    // Who may change FA00/FA01, decided from the requests in the order the intake took them,
    // with no help from the lease policy: a write takes a free lease, a take-over takes it from
    // its holder, the holder's token renews it, a release or lease_ms without renewal ends it.
    void model_leases() {
        std::optional<shm::LeaseToken> holder;
        rtu::Instant last{};
        bool uncertain = false;
        for (Sent& s : sent_) {
            ASSERT_TRUE(s.answered) << "seed " << seed_ << ": a request never answered: " << clients_[s.client].name
                                    << " kind " << int(s.request.kind) << " at 0x" << std::hex << s.request.start
                                    << std::dec << " count " << s.request.count << ", sent at line time "
                                    << std::chrono::duration<double>(s.accepted - kStart).count() << " s of "
                                    << std::chrono::duration<double>(line_->now() - kStart).count();
            const rtu::Instant t = s.accepted;
            if (holder && !uncertain) {
                const auto idle = t - last;
                if (idle >= kLease + kLeaseMargin) {
                    holder.reset();  // ran out: its fallback followed
                } else if (idle + kLeaseMargin > kLease) {
                    uncertain = true;
                }
            }
            const auto status = s.response.status;
            const bool admitted =
                status != shm::Status::Rejected && status != shm::Status::QueueFull && status != shm::Status::BusDown;
            const bool granted = s.response.lease_token != shm::LeaseToken{};
            const bool take_over = (s.request.flags & shm::kFlagTakeOver) != 0;
            if (granted) {
                ++grants_;
                EXPECT_TRUE(uncertain || !holder || take_over)
                    << "seed " << seed_ << ": the lease was granted to " << clients_[s.client].name
                    << " while another client held it, without a take-over";
                holder = s.response.lease_token;
                last = t;
                uncertain = false;
            }
            if (s.command && admitted) {
                if (granted) {
                    s.verdict = Verdict::Valid;
                } else if (uncertain) {
                    s.verdict = Verdict::Uncertain;
                } else if (holder && s.request.lease_token == *holder) {
                    s.verdict = Verdict::Valid;
                    last = t;
                } else {
                    s.verdict = Verdict::Invalid;
                }
            } else if (s.command) {
                s.verdict = Verdict::Invalid;  // refused before the lease: never sent
            }
            if (s.verdict == Verdict::Invalid) {
                EXPECT_TRUE(status == shm::Status::NotPermitted || !admitted)
                    << "seed " << seed_ << ": " << clients_[s.client].name << "'s command was answered " << int(status)
                    << " though it did not hold the lease";
            }
            if (s.request.kind == shm::RequestKind::LeaseRenew && status == shm::Status::Ok && !uncertain) {
                EXPECT_TRUE(holder && s.request.lease_token == *holder)
                    << "seed " << seed_ << ": a renewal without the holder's token was answered Ok";
                last = t;
            }
            if (s.request.kind == shm::RequestKind::LeaseRelease && status == shm::Status::Ok && holder &&
                s.request.lease_token == *holder) {
                holder.reset();
                uncertain = false;
            }
        }
    }

    std::uint64_t seed_;
    std::mt19937_64 rng_;
    std::shared_ptr<const Profile> atv21_ = load("atv21");
    std::shared_ptr<const Profile> atv58_ = load("atv58");
    config::BusConfig config_ = bus<config::BusConfig>();
    rtu::CharacterTiming timing_ = rtu::character_timing(config_.format).value();
    sim::Bus drives_{{timing_, 1ms, true, 3}};
    std::unique_ptr<bus::Handover> handover_;
    std::unique_ptr<bus::Desk> desk_;
    std::unique_ptr<master::BusEngine> engine_;
    std::unique_ptr<VirtualLine> line_;
    std::unique_ptr<ipc::LeasePolicy> leases_;
    std::unique_ptr<ipc::IntakeCore> intake_;
    std::vector<Client> clients_;
    std::map<std::uint16_t, std::uint16_t> selectors_;  // as drivebusd set them up
    std::vector<Sent> sent_;
    std::map<std::uint16_t, Route> by_reference_;
    struct Held {
        rtu::Instant at{};
        std::map<std::uint16_t, std::uint16_t> values;
    };
    std::map<rtu::SlaveAddress, std::deque<Held>> history_;
    std::uint64_t correlation_ = 0;
    std::uint64_t reference_ = 0;
    std::size_t snapshot_values_ = 0;
    std::size_t read_values_ = 0;
    std::size_t unverifiable_ = 0;
    std::size_t references_landed_ = 0;
    std::size_t grants_ = 0;
    std::optional<rtu::Instant> off_until_;
    std::size_t power_cycles_ = 0;
};

std::uint64_t seed_from_env(std::uint64_t fallback) {
    const char* text = std::getenv("DRIVEBUS_INTEGRITY_SEED");
    return text != nullptr ? std::stoull(text) : fallback;
}

TEST(Integrity, RandomClientsNeverCorruptAValueNorCommandADriveWithoutTheLease) {
    for (const std::uint64_t seed : {seed_from_env(20261202), std::uint64_t{std::random_device{}()}}) {
        Integrity run(seed);
        run.run(3000);
        run.check_leases();
        std::cout << run.summary() << "\n";
        // The run did what it is for: values were checked, references landed from holders,
        // impostors' commands were refused, and leases ran out.
        EXPECT_GT(run.snapshot_values(), 1000U) << run.summary();
        EXPECT_GT(run.read_values(), 100U) << run.summary();
        EXPECT_GT(run.references_landed(), 50U) << run.summary();
        EXPECT_GT(run.invalid_commands(), 50U) << run.summary();
        EXPECT_GT(run.expiries(), 0U) << run.summary();
        EXPECT_GT(run.power_cycles(), 0U) << run.summary();
        if (::testing::Test::HasFailure()) {
            break;
        }
    }
}

}  // namespace
}  // namespace drivebus::test
