// SPDX-License-Identifier: Apache-2.0
#include "bus/bus_loop.hpp"

#include <pthread.h>
#include <unistd.h>

#include <future>
#include <stdexcept>

#include "bus/bus_thread.hpp"
#include "log/log.hpp"
#include "rt/memory.hpp"
#include "rt/realtime.hpp"

namespace drivebus::bus {

namespace {}  // namespace

BusLoop::BusLoop(const config::BusConfig& bus, master::EngineCallbacks callbacks, LoopOptions options)
    : bus_(bus),
      callbacks_(std::move(callbacks)),
      options_(std::move(options)),
      handover_(bus.queue_limit, bus.drives.size()),
      wake_("eventfd for the bus thread") {}

BusLoop::~BusLoop() {
    stop();
}

std::expected<void, std::string> BusLoop::start() {
    auto created = Impl::create(bus_, callbacks_, options_, *this);
    if (!created) {
        return std::unexpected(created.error());
    }
    impl_ = std::move(*created);
    std::promise<std::expected<void, std::string>> started;
    auto ready = started.get_future();
    thread_ = std::thread([this, &started] {
        // Named so that top -H and /proc/PID/task/*/comm tell the bus threads apart.
        (void)::pthread_setname_np(::pthread_self(), ("bus " + bus_.name).substr(0, 15).c_str());
        log_.use_on_this_thread();
        const log::ThreadFields fields({.bus = bus_.name});  // BUS= on every line of this thread
        if (options_.realtime && options_.realtime->mode != config::RealtimeMode::Off) {
            auto rt = rt::make_realtime(options_.realtime->priority, options_.realtime->cpus);
            if (!rt) {
                if (options_.realtime->mode == config::RealtimeMode::Required) {
                    started.set_value(std::unexpected("bus " + bus_.name + ": " + rt.error()));
                    return;
                }
                log::warning("bus " + bus_.name + ": " + rt.error() + "; running best-effort");
            }
        }
        // Resident before the memory is locked (which locks what is resident, and the rest of
        // a stack only as it is touched): the loop's first deep call must not fault.
        rt::prefault_stack();
        started.set_value({});
        impl_->run();
    });
    auto result = ready.get();
    if (!result) {
        thread_.join();
        impl_.reset();
    }
    return result;
}

void BusLoop::stop() {
    if (thread_.joinable()) {
        impl_->request_stop();
        thread_.join();
    }
}

void BusLoop::wind_down() {
    winding_.store(true);
    wake_.signal();
}

std::expected<void, master::SubmitError> BusLoop::submit(const master::ClientRequest& request) {
    if (!handover_.requests.try_push(request)) {
        return std::unexpected(master::SubmitError::QueueFull);
    }
    wake_.signal();
    return {};
}

master::BusStatus BusLoop::status() const {
    const StatusCopy c = status_.load();
    master::BusStatus s;
    s.name = bus_.name;
    s.up = c.up;
    s.counters = c.counters;
    s.reply_latency = c.reply_latency;
    s.extra_gap = c.extra_gap;
    s.sequence = c.sequence;
    return s;
}

}  // namespace drivebus::bus
