// SPDX-License-Identifier: Apache-2.0
// A deterministic, virtual RS485 line: the master's BusEngine on one end, simulated drives
// (the simulator's pure Bus) on the other, and a clock that jumps from event to event. No
// threads, no sleeps, no ptys: every character's time is exact.
//
// What reaches the master can be held back, as the kernel's tty worker does on a busy
// machine: a delivery function says when each byte of a reply is handed over (never before
// it is on the wire, never before the byte ahead of it); bytes handed over together arrive in
// one read. The silences the line keeps are judged on the wire's own times.
#pragma once

#include <algorithm>
#include <deque>
#include <functional>
#include <vector>

#include "bus.hpp"
#include "master/bus_engine.hpp"
#include "rtu/framer.hpp"

namespace drivebus::test {

class VirtualLine {
public:
    struct Transmission {
        rtu::Instant start{};           // when the master wrote it
        rtu::Instant free_at{};         // last line activity + t3.5 at that moment, as the engine saw it
        rtu::Instant prior_activity{};  // the end of the last character on the line before it
        rtu::Adu adu;
    };

    // When byte `index` of reply number `reply` (counted from 0), on the wire at `at`, is
    // handed to the master.
    using Delivery = std::function<rtu::Instant(std::size_t reply, std::size_t index, rtu::Instant at)>;

    VirtualLine(master::BusEngine& engine, sim::Bus& drives, rtu::CharacterTiming timing, rtu::Instant start)
        : engine_(engine),
          drives_(drives),
          timing_(timing),
          now_(start),
          slave_framer_(timing, rtu::InputMarking::Plain) {}

    // Runs the line until `end`.
    void run_until(rtu::Instant end) {
        for (int guard = 0; guard < 10'000'000; ++guard) {
            if (auto adu = engine_.transmission(now_)) {
                send(*adu);
                continue;
            }
            const auto next = next_event();
            if (!next || *next > end) {
                now_ = end;
                engine_.on_time(now_);
                return;
            }
            now_ = std::max(now_, *next);
            step();
        }
        throw std::runtime_error("virtual line did not settle");
    }
    void run_for(rtu::Duration d) { run_until(now_ + d); }
    // Runs until `done` holds or `limit` of line time has passed; false on the limit.
    bool run_until_true(const std::function<bool()>& done, rtu::Duration limit) {
        const rtu::Instant end = now_ + limit;
        while (!done()) {
            if (now_ >= end) {
                return false;
            }
            run_until(std::min(end, now_ + std::chrono::milliseconds(5)));
        }
        return true;
    }
    void set_delivery(Delivery delivery) { delivery_ = std::move(delivery); }
    // Told of every request frame the drives have just handled, at that time: what they hold
    // now is what their reply carries.
    using Handled = std::function<void(const rtu::Frame& request, rtu::Instant at)>;
    void set_handled(Handled handled) { handled_ = std::move(handled); }
    // Whether transmissions() keeps every request (a long soak keeps its own short record).
    void set_recording(bool on) noexcept { recording_ = on; }
    [[nodiscard]] std::size_t replies() const noexcept { return replies_; }

    [[nodiscard]] rtu::Instant now() const noexcept { return now_; }
    [[nodiscard]] const std::vector<Transmission>& transmissions() const noexcept { return sent_; }
    // The end of the last character on the line, either way.
    [[nodiscard]] rtu::Instant last_activity() const noexcept { return last_activity_; }

private:
    struct Pending {
        sim::TxByte byte;
        rtu::Instant deliver{};
    };

    void send(const rtu::Adu& adu) {
        // The wire's last activity includes what is on it and not yet handed to the master.
        rtu::Instant prior = last_activity_;
        for (const auto& p : to_master_) {
            if (p.byte.at <= now_) {
                prior = std::max(prior, p.byte.at);
            }
        }
        if (recording_) {
            sent_.push_back({now_, engine_.line_free_at(), prior, adu});
        }
        engine_.written(now_);
        const rtu::Instant tx_end = now_ + timing_.character * static_cast<std::int64_t>(adu.size());
        pending_tx_end_ = tx_end;
        last_activity_ = std::max(last_activity_, tx_end);
        // The drives receive it at wire speed, ending at tx_end.
        const std::vector<std::uint8_t> bytes(adu.bytes().begin(), adu.bytes().end());
        slave_framer_.feed(bytes, tx_end);
        for (const auto& b : drives_.on_received(bytes, tx_end)) {
            to_master_.push_back({b, b.at});  // echo, already in time order
        }
    }

    void queue_reply(const sim::TxPlan& plan) {
        std::size_t index = 0;
        for (const auto& b : plan) {
            const auto pos = std::upper_bound(to_master_.begin(), to_master_.end(), b.at,
                                              [](rtu::Instant t, const Pending& x) { return t < x.byte.at; });
            rtu::Instant deliver = delivery_ ? std::max(b.at, delivery_(replies_, index, b.at)) : b.at;
            if (pos != to_master_.begin()) {
                deliver = std::max(deliver, std::prev(pos)->deliver);  // first in, first out
            }
            to_master_.insert(pos, {b, deliver});
            ++index;
        }
        ++replies_;
    }

    std::optional<rtu::Instant> next_event() const {
        std::optional<rtu::Instant> t;
        auto consider = [&](std::optional<rtu::Instant> x) {
            if (x && (!t || *x < *t)) {
                t = x;
            }
        };
        consider(engine_.next_wakeup());
        consider(pending_tx_end_);
        consider(slave_framer_.deadline());
        if (!to_master_.empty()) {
            consider(to_master_.front().deliver);
        }
        return t;
    }

    void step() {
        if (pending_tx_end_ && *pending_tx_end_ <= now_) {
            engine_.transmitted(*pending_tx_end_);
            pending_tx_end_.reset();
        }
        slave_framer_.poll(now_);
        while (auto event = slave_framer_.next_event()) {
            if (const auto* frame = std::get_if<rtu::Frame>(&*event)) {
                queue_reply(drives_.on_frame(*frame));
                if (handled_) {
                    handled_(*frame, now_);
                }
            }
        }
        // What the kernel hands over by now arrives in one read; PARMRK doubles a data 0xFF,
        // as a real UART's marked input does.
        std::vector<std::uint8_t> read;
        while (!to_master_.empty() && to_master_.front().deliver <= now_) {
            const sim::TxByte b = to_master_.front().byte;
            to_master_.pop_front();
            last_activity_ = std::max(last_activity_, b.at);
            read.push_back(b.value);
            if (b.value == 0xFF) {
                read.push_back(0xFF);
            }
            if (!delivery_) {
                engine_.on_bytes(read, b.at);  // on time: one character per read, at its end
                read.clear();
            }
        }
        if (!read.empty()) {
            engine_.on_bytes(read, now_);
        }
        engine_.on_time(now_);
    }

    master::BusEngine& engine_;
    sim::Bus& drives_;
    rtu::CharacterTiming timing_;
    rtu::Instant now_;
    rtu::Framer slave_framer_;
    std::deque<Pending> to_master_;
    Delivery delivery_;
    Handled handled_;
    bool recording_ = true;
    std::size_t replies_ = 0;
    std::optional<rtu::Instant> pending_tx_end_;
    std::vector<Transmission> sent_;
    rtu::Instant last_activity_{};
};

}  // namespace drivebus::test
