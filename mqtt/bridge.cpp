// SPDX-License-Identifier: Apache-2.0
#include "bridge.hpp"

#include <poll.h>

#include <algorithm>
#include <vector>

#include "log/log.hpp"

namespace drivebus::mqtt {
namespace {

using namespace std::chrono_literals;

void log_note(const RelayNote& n) {
    const log::Fields fields{.bus = n.bus, .drive = n.drive};
    switch (n.level) {
    case RelayNote::Level::Debug: log::debug(n.text, fields); break;
    case RelayNote::Level::Notice: log::notice(n.text, fields); break;
    case RelayNote::Level::Warning: log::warning(n.text, fields); break;
    }
}

}  // namespace

Bridge::Bridge(const Config& config) : config_(config), topics_(config.node), inbox_(config.limits.command_queue) {
    link_ = std::make_unique<BrokerLink>(
        config_, BrokerLink::Callbacks{.connected = [this] { on_connected(); },
                                       .message = [this](std::string_view t, std::string_view p,
                                                         bool retained) { on_message(t, p, retained); }});
    relay_ = std::make_unique<Relay>(config_, *link_, daemon_, log_note);
}

Bridge::~Bridge() {
    stop();
    link_.reset();   // its network thread ends: nothing queues any more
    relay_.reset();  // the drives' subscriptions, then the buses
}

void Bridge::stop() {
    {
        std::lock_guard lock(mutex_);
        stopping_ = true;
    }
    wake();
}

// On the network thread.
void Bridge::on_connected() {
    {
        std::lock_guard lock(mutex_);
        republish_ = true;
    }
    wake();
}

// On the network thread: queued for the loop, which wakes; past the inbox's bound, refused at
// once (mqtt/inbox.hpp).
void Bridge::on_message(std::string_view topic, std::string_view payload, bool retained) {
    const auto received = std::chrono::system_clock::now();
    const auto arrived = Clock::now();
    auto target = topics_.parse_set(topic);
    if (!target) {
        return;
    }
    std::optional<Inbound> refused;
    {
        std::lock_guard lock(mutex_);
        refused = inbox_.offer(Inbound{std::move(*target), std::string(payload), retained, received, arrived});
    }
    if (!refused) {
        wake();
        return;
    }
    const auto result = refused_busy(*refused, config_.limits.max_payload);
    link_->publish(topics_.result(result.bus, result.drive), result.payload.dump(), 1, false);
}

void Bridge::run() {
    link_->start();
    std::vector<pollfd> fds;
    for (;;) {
        fds.assign(1, pollfd{.fd = wake_.fd(), .events = POLLIN, .revents = 0});
        for (const int fd : relay_->descriptors()) {
            fds.push_back(pollfd{.fd = fd, .events = POLLIN, .revents = 0});
        }
        const auto before = Clock::now();
        // At least 10 ms: a deadline just passed does not spin the loop.
        const auto wait = std::max(std::chrono::ceil<std::chrono::milliseconds>(relay_->next_deadline(before) - before),
                                   std::chrono::milliseconds(10));
        (void)::poll(fds.data(), fds.size(), static_cast<int>(wait.count()));  // EINTR: round again
        wake_.drain();
        relay_->dispatch(Clock::now());  // snapshots, statuses, commands' answers; returns at once if none
        bool republish = false;
        std::deque<Inbound> taken;
        {
            std::lock_guard lock(mutex_);
            if (stopping_) {
                break;
            }
            republish = std::exchange(republish_, false);
            taken = inbox_.take();
        }
        for (auto& m : taken) {
            relay_->message(m.target, m.payload, m.retained, m.received, m.arrived);
        }
        relay_->turn(Clock::now(), republish);
    }
    link_->stop();
    const auto c = link_->counters();
    const auto& commands = relay_->commands();
    log::notice("stopped: " + std::to_string(relay_->counters().states_published) + " states published, " +
                std::to_string(commands.commands) + " commands carried out, " +
                std::to_string(commands.commands_refused) + " refused, " + std::to_string(c.dropped) +
                " messages dropped, " + std::to_string(c.connections) + " broker connections");
}

}  // namespace drivebus::mqtt
