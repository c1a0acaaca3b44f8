// A deterministic, virtual RS485 line: the master's BusEngine on one end, simulated drives
// (the simulator's pure Bus) on the other, and a clock that jumps from event to event. No
// threads, no sleeps, no ptys: every character's time is exact.
#pragma once

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

    [[nodiscard]] rtu::Instant now() const noexcept { return now_; }
    [[nodiscard]] const std::vector<Transmission>& transmissions() const noexcept { return sent_; }
    // The end of the last character on the line, either way.
    [[nodiscard]] rtu::Instant last_activity() const noexcept { return last_activity_; }

private:
    void send(const rtu::Adu& adu) {
        sent_.push_back({now_, engine_.line_free_at(), last_activity_, adu});
        engine_.written(now_);
        const rtu::Instant tx_end = now_ + timing_.character * static_cast<std::int64_t>(adu.size());
        pending_tx_end_ = tx_end;
        last_activity_ = std::max(last_activity_, tx_end);
        // The drives receive it at wire speed, ending at tx_end.
        const std::vector<std::uint8_t> bytes(adu.bytes().begin(), adu.bytes().end());
        slave_framer_.feed(bytes, tx_end);
        for (const auto& b : drives_.on_received(bytes, tx_end)) {
            to_master_.push_back(b);  // echo, already in time order
        }
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
            consider(to_master_.front().at);
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
                for (const auto& b : drives_.on_frame(*frame)) {
                    const auto pos = std::upper_bound(to_master_.begin(), to_master_.end(), b.at,
                                                      [](rtu::Instant t, const sim::TxByte& x) { return t < x.at; });
                    to_master_.insert(pos, b);
                }
            }
        }
        while (!to_master_.empty() && to_master_.front().at <= now_) {
            const sim::TxByte b = to_master_.front();
            to_master_.pop_front();
            last_activity_ = std::max(last_activity_, b.at);
            const std::uint8_t value = b.value;
            // PARMRK doubles a data 0xFF; the engine expects marked input as a real UART gives.
            if (value == 0xFF) {
                const std::array<std::uint8_t, 2> escaped{0xFF, 0xFF};
                engine_.on_bytes(escaped, b.at);
            } else {
                engine_.on_bytes(std::span(&value, 1), b.at);
            }
        }
        engine_.on_time(now_);
    }

    master::BusEngine& engine_;
    sim::Bus& drives_;
    rtu::CharacterTiming timing_;
    rtu::Instant now_;
    rtu::Framer slave_framer_;
    std::deque<sim::TxByte> to_master_;
    std::optional<rtu::Instant> pending_tx_end_;
    std::vector<Transmission> sent_;
    rtu::Instant last_activity_{};
};

}  // namespace drivebus::test
