// SPDX-License-Identifier: Apache-2.0
#include "bus/bus_thread.hpp"

#include <poll.h>
#include <unistd.h>

#include <array>

#include "bus/desk.hpp"
#include "bus/line_opener.hpp"
#include "log/log.hpp"
#include "master/mute_watch.hpp"
#include "serial/direction.hpp"
#include "serial/port.hpp"
#include "serial/tx_tracker.hpp"
#include "sys/event_loop.hpp"

namespace drivebus::bus {

namespace {

class BusThread final : public BusLoop::Impl {
public:
    BusThread(const config::BusConfig& bus, const master::EngineCallbacks& callbacks, const LoopOptions& options,
              const BusLoop::Impl::Shared& shared)
        : bus_(bus),
          options_(options),
          up_(shared.up),
          handover_(shared.handover),
          status_(shared.status),
          timing_(rtu::character_timing(bus.format).value()),
          desk_(bus, shared.handover),
          engine_(bus, timing_, desk_.callbacks(callbacks), sys::now()),
          uart_(serial::kernel_uart_control()),
          heartbeat_(shared.heartbeat),
          wake_(shared.wake),
          winding_(shared.winding) {
        desk_.attach(engine_);
        auto woken = loop_.add(wake_.fd(), [this] { on_wake(); });
        auto timed = loop_.add(timer_.fd(), [this] {
            timer_.acknowledge();
            armed_.reset();
            drive();
        });
        if (!woken || !timed) {
            broken_ = "bus " + bus_.name + ": event loop: " + (!woken ? woken : timed).error().message();
        }
    }

    // Why the loop cannot run, found when it was built (before its thread starts).
    [[nodiscard]] const std::optional<std::string>& broken() const noexcept { return broken_; }

    void run() override {
        // What waits in the ring before the line opens: the fallbacks of the leases the last
        // drivebusd held when it ended, which go out before anything else.
        desk_.take_requests();
        try_open();
        drive();
        if (auto ran = loop_.run(); !ran) {
            log::error("bus " + bus_.name + ": event loop: " + ran.error().message());
        }
        close_port();
        // Every request the bus had is answered before the thread ends (a reload restarting
        // the bus answers its clients from these): the one on the wire and those waiting as
        // the line going down does, those still in the ring refused, bus down.
        engine_.line_down(sys::now());
        desk_.take_requests();
    }

    void request_stop() noexcept override {
        stopping_ = true;
        wake_.signal();
    }

private:
    void on_wake() {
        wake_.drain();
        if (stopping_) {
            loop_.stop();
            return;
        }
        // Read before the ring: the fallbacks submitted before the wind-down are then taken.
        const bool winding = winding_.load();
        desk_.take_requests();
        if (winding && !engine_.winding_down()) {
            engine_.wind_down(sys::now());
        }
        drive();
    }

    // ---- the port ----

    void try_open() {
        auto line = opener_.open(sys::now());
        if (!line) {
            return;
        }
        port_ = std::move(line->port);
        direction_ = std::move(line->direction);
        tracker_.emplace(timing_, *uart_, port_->fd());
        if (auto added = loop_.add(port_->fd(), [this](sys::Readiness ready) { on_readable(ready); }); !added) {
            close_port();
            opener_.failed("event loop: " + added.error().message(), false, sys::now());
            return;
        }
        engine_.line_up(sys::now());
        mute_.opened(engine_.status().counters, sys::now());
    }

    // Open and hearing nothing while its requests time out: the adapter may have stopped
    // delivering (a known ftdi_sio failure), and only a close and open brings it back.
    void reopen_if_mute(rtu::Instant now) {
        if (!port_ || !mute_.mute(engine_.status().counters, now)) {
            return;
        }
        limiter_.write(
            log::Level::Warning, "mute",
            "bus " + bus_.name + ": " + port_->device().string() + ": nothing received for " +
                std::to_string(std::chrono::duration_cast<std::chrono::seconds>(mute_.silent_for()).count()) +
                " s while every request timed out; reopening the port",
            {.bus = bus_.name});
        close_port();
        engine_.line_down(now);
        engine_.count_mute_reopen();
        try_open();
    }

    void close_port() {
        if (port_) {
            loop_.remove(port_->fd());
            port_.reset();
        }
        sending_.reset();
        waiting_for_room_ = false;
        direction_.reset();
        tracker_.reset();
    }

    void lost(const std::string& why) {
        log::error("bus " + bus_.name + ": " + why + "; bus down");
        close_port();
        engine_.line_down(sys::now());
        opener_.failed(bus_.device.string() + ": gone", true, sys::now());
    }

    // A hang-up (the adapter unplugged, the tty vhangup()ed) is the line going down, at once:
    // the descriptor stays ready for ever, and reading on would spin the bus thread. drive()
    // then shows the bus down and arms the timer for the reopen.
    void on_readable(sys::Readiness ready) {
        if (ready.hung_up) {
            lost(port_->device().string() + ": hung up");
        }
        if (ready.writable && port_ && sending_) {
            continue_sending();
        }
        std::array<std::uint8_t, 512> buffer{};
        while (port_) {
            auto n = port_->read(buffer);
            const rtu::Instant t = sys::now();
            if (!n) {
                lost(port_->device().string() + ": " + n.error().message());
                break;
            }
            if (*n == 0) {
                break;
            }
            engine_.on_bytes(std::span(buffer.data(), *n), t);
            // A short read emptied the input; what comes later wakes the loop again. Reading
            // on to EAGAIN would add a syscall to every character's wake-up.
            if (*n < buffer.size()) {
                break;
            }
        }
        drive();
    }

    // ---- the engine ----

    void drive() {
        // Every wake-up ends here: what it handed over wakes the ipc side once, on the way out.
        const Flush flush{handover_};
        heartbeat_.fetch_add(1, std::memory_order_relaxed);
        rtu::Instant now = sys::now();
        if (!port_) {
            if (const auto next = opener_.next_try(); next && now >= *next) {
                try_open();
            }
        }
        desk_.retry_fallbacks(now);
        engine_.on_time(now);
        reopen_if_mute(now);
        if (port_ && tracker_ && tracker_->busy() && now >= tracker_->next_check()) {
            if (const auto done = tracker_->check(now)) {
                if (auto released = direction_->transmit_done(sys::now()); !released) {
                    lost(released.error().message);
                    return;
                }
                log_edges(*done);
                engine_.transmitted(*done);
                engine_.on_time(now);
            }
        }
        if (port_ && sending_ && now >= sending_->give_up) {
            lost(port_->device().string() + ": output stalled, the port took no more of the request");
        }
        if (port_ && tracker_ && !tracker_->busy() && !sending_) {
            transmit(now);
        }
        publish_status();
        arm();
    }

    // With drivebusd switching the driver itself, the debug log shows each request's edges:
    // enabled before the write, released after the transmitter emptied.
    void log_edges(rtu::Instant tx_end) {
        const auto& edges = direction_->edges();
        if (log::enabled(log::Level::Debug) && direction_->needs_release() && edges.size() >= 2 && written_at_) {
            const auto us = [](rtu::Duration d) { return std::to_string(d.count() / 1000); };
            const auto& on = edges[edges.size() - 2];
            const auto& off = edges.back();
            log::debug("bus " + bus_.name + ": " + std::string(direction_->name()) + " enabled " +
                       us(*written_at_ - on.at) + " us before the write, released " + us(off.at - tx_end) +
                       " us after the transmitter emptied (" + us(tx_end - *written_at_) + " us on the wire)");
        }
        direction_->clear_edges();
    }

    void transmit(rtu::Instant now) {
        if (!spin_to_send(now)) {
            return;
        }
        // Only a trace needs to know when the request became due (the scheduler's drives are
        // looked through for it, on every wake-up).
        const rtu::Instant due =
            options_.on_written ? engine_.next_send_at().value_or(engine_.line_free_at()) : rtu::Instant{};
        // Bytes already in the input queue mean the line is not silent: read them first (the
        // port is readable, so the loop comes back here after on_readable()).
        const std::size_t waiting = engine_.line_free(now) ? port_->input_waiting() : 0;
        const auto adu = engine_.transmission(now, waiting);
        if (!adu) {
            return;
        }
        if (auto enabled = direction_->before_transmit(sys::now()); !enabled) {
            lost(enabled.error().message);
            return;
        }
        const rtu::Instant writing = sys::now();
        sending_ = Sending{*adu, 0, due, writing, writing + options_.output_stall};
        continue_sending();
    }

    // Writes what the port takes of the request being sent. When its output buffer is full the
    // loop waits for room (EPOLLOUT) with everything else, and comes back here; the request
    // counts as written once the port has taken all of it.
    void continue_sending() {
        while (sending_->done < sending_->adu.size()) {
            auto n = port_->write(sending_->adu.bytes().subspan(sending_->done));
            if (!n) {
                lost(port_->device().string() + ": " + n.error().message());
                return;
            }
            if (*n == 0) {
                if (!waiting_for_room_) {
                    if (auto watched = loop_.watch_writable(port_->fd(), true); !watched) {
                        lost(port_->device().string() + ": " + watched.error().message());
                        return;
                    }
                    waiting_for_room_ = true;
                }
                return;
            }
            sending_->done += *n;
        }
        if (waiting_for_room_) {
            (void)loop_.watch_writable(port_->fd(), false);
            waiting_for_room_ = false;
        }
        const Sending sent = *sending_;
        sending_.reset();
        const rtu::Instant written = sys::now();
        written_at_ = written;
        engine_.written(written);
        tracker_->started(written, sent.adu.size());
        if (options_.on_written) {
            options_.on_written(WriteTrace{sent.due, sent.writing, written, engine_.attempts(), engine_.scheduled()});
        }
    }

    // With send_spin set, the timer wakes the thread that much before a request is due (see
    // arm()), and the last stretch is spent on the clock: a timer's wake-up is late by tens of
    // microseconds, the clock is not. A character arriving meanwhile ends the spin; it moves
    // the silence, and the loop handles it first. `now` becomes the send time. False: not yet.
    bool spin_to_send(rtu::Instant& now) {
        if (options_.send_spin.count() <= 0) {
            return true;
        }
        const auto send_at = engine_.next_send_at();
        if (!send_at || *send_at <= now || *send_at - now > options_.send_spin) {
            return true;
        }
        pollfd p{port_->fd(), POLLIN, 0};
        while ((now = sys::now()) < *send_at) {
            if (::poll(&p, 1, 0) > 0) {
                return false;
            }
        }
        return true;
    }

    void arm() {
        std::optional<rtu::Instant> wake = engine_.next_wakeup();
        auto consider = [&](std::optional<rtu::Instant> t) {
            if (t && (!wake || *t < *wake)) {
                wake = t;
            }
        };
        if (tracker_ && tracker_->busy()) {
            consider(tracker_->next_check());
        }
        consider(port_ ? mute_.next_check() : opener_.next_try());
        if (sending_) {
            consider(sending_->give_up);
        }
        consider(desk_.next_retry());
        // The loop goes round at least this often, so that its heartbeat shows it is alive
        // even on a quiet bus (the service watchdog watches it).
        const rtu::Instant now = sys::now();
        consider(now + kLivenessTick);
        if (options_.send_spin.count() > 0) {
            if (const auto send_at = engine_.next_send_at();
                send_at && *send_at == *wake && *wake - now > options_.send_spin) {
                *wake -= options_.send_spin;
            }
        }
        // While a reply comes in, each character moves the frame's deadline later. A timer
        // already armed for an earlier, future instant stays: when it fires, drive() runs and
        // arms the later one. That saves a timerfd_settime per character.
        if (armed_ && *armed_ > now && *armed_ <= *wake) {
            return;
        }
        if (auto ok = timer_.arm(*wake); !ok) {
            // Not armed: the next event on the loop (a character, a request) tries again.
            limiter_.write(log::Level::Error, "timer", "bus " + bus_.name + ": " + ok.error().message());
            return;
        }
        armed_ = wake;
    }

    struct Flush {
        explicit Flush(Handover& h) noexcept : handover(h) {}
        Handover& handover;
        Flush(const Flush&) = delete;
        Flush& operator=(const Flush&) = delete;
        Flush(Flush&&) = delete;
        Flush& operator=(Flush&&) = delete;
        ~Flush() { handover.flush(); }
    };

    static constexpr rtu::Duration kLivenessTick = std::chrono::milliseconds(500);

    // Other threads read the status a few times a second; copying it on every wake-up (once
    // per received character) would cost more than all the rest of the wake-up.
    void publish_status() {
        const rtu::Instant now = sys::now();
        const auto& status = engine_.status();
        up_.store(status.up, std::memory_order_relaxed);
        if (now < next_status_copy_ && status.up == status_copy_up_) {
            return;
        }
        next_status_copy_ = now + kStatusCopyInterval;
        status_copy_up_ = status.up;
        status_.store(StatusCopy{status.up, status.counters, status.reply_latency, status.extra_gap, status.sequence});
    }

    static constexpr rtu::Duration kStatusCopyInterval = std::chrono::milliseconds(5);
    rtu::Instant next_status_copy_{};
    bool status_copy_up_ = false;
    std::optional<rtu::Instant> armed_;
    std::optional<std::string> broken_;
    // A request the port has not taken whole yet.
    struct Sending {
        rtu::Adu adu;
        std::size_t done = 0;
        rtu::Instant due;
        rtu::Instant writing;
        rtu::Instant give_up;
    };
    std::optional<Sending> sending_;
    bool waiting_for_room_ = false;

    const config::BusConfig& bus_;
    const LoopOptions& options_;
    std::atomic<bool>& up_;
    Handover& handover_;
    sys::Seqlock<StatusCopy>& status_;
    rtu::CharacterTiming timing_;
    Desk desk_;
    master::BusEngine engine_;
    std::unique_ptr<serial::UartControl> uart_;
    LineOpener opener_{bus_, *uart_};
    master::MuteWatch mute_{bus_.mute_reopen, std::chrono::minutes(5)};
    std::atomic<std::uint64_t>& heartbeat_;
    sys::EventLoop loop_;
    sys::Timer timer_;
    const sys::EventFd& wake_;
    const std::atomic<bool>& winding_;
    std::optional<serial::Port> port_;
    std::unique_ptr<serial::Direction> direction_;
    std::optional<serial::TransmitTracker> tracker_;
    std::optional<rtu::Instant> written_at_;
    log::RateLimited limiter_{std::chrono::seconds(60)};
    std::atomic<bool> stopping_{false};
};

}  // namespace

std::expected<std::unique_ptr<BusLoop::Impl>, std::string> BusLoop::Impl::create(
    const config::BusConfig& bus, const master::EngineCallbacks& callbacks, const LoopOptions& options,
    BusLoop& outer) {
    const Shared shared{outer.up_, outer.handover_, outer.status_, outer.heartbeat_, outer.wake_, outer.winding_};
    auto thread = std::make_unique<BusThread>(bus, callbacks, options, shared);
    if (const auto& broken = thread->broken()) {
        return std::unexpected(*broken);
    }
    return thread;
}

}  // namespace drivebus::bus
