// SPDX-License-Identifier: Apache-2.0
// Commands from the broker: the network thread queues them, the loop hands them to the
// Commander (mqtt/commander.hpp, where every rule is) and carries out what it asks: each step a
// libdrivebus request answered by callback on the loop's thread, each result published.
#include <algorithm>
#include <array>

#include "bridge.hpp"
#include "bridge_links.hpp"
#include "log/log.hpp"

namespace drivebus::mqtt {
namespace {

// Rounded down: the deadline is counted again from libdrivebus's call, a little later.
WriteOptions write_options(std::optional<std::chrono::nanoseconds> left) {
    WriteOptions options;
    if (left) {
        options.deadline = std::chrono::floor<Milliseconds>(*left);
    }
    return options;
}

}  // namespace

bool Bridge::Fleet::has_bus(std::string_view bus) const {
    return std::ranges::any_of(bridge_.buses_, [&](const auto& b) { return b->settings.name == bus; });
}

std::optional<Roster::Drive> Bridge::Fleet::drive(std::string_view bus, std::string_view drive) const {
    const DriveLink* d = bridge_.find(bus, drive);
    if (d == nullptr) {
        return std::nullopt;
    }
    return Drive{.commands = d->settings.commands, .profile = d->drive.profile()};
}

Bridge::DriveLink* Bridge::find(std::string_view bus, std::string_view drive) const {
    for (const auto& b : buses_) {
        if (b->settings.name != bus) {
            continue;
        }
        for (const auto& d : b->drives) {
            if (d->settings.name == drive) {
                return d.get();
            }
        }
    }
    return nullptr;
}

// On the network thread: queued for the loop, which wakes. Bounded: past the Commander's own
// queue and as many again arriving at once, a command is refused here, without parsing more
// than its id.
void Bridge::on_message(std::string_view topic, std::string_view payload, bool retained) {
    const auto received = std::chrono::system_clock::now();
    const auto arrived = Clock::now();
    auto target = topics_.parse_set(topic);
    if (!target) {
        return;
    }
    {
        std::lock_guard lock(mutex_);
        if (inbox_.size() < 2 * config_.limits.command_queue + 16) {
            inbox_.push_back(Inbound{std::move(*target), std::string(payload), retained, received, arrived});
            wake();
            return;
        }
    }
    const auto parsed = parse_command(payload, config_.limits.max_payload);
    const Json id = parsed ? parsed->id : parsed.error().id;
    link_->publish(
        topics_.result(target->bus, target->drive),
        result_error(id, "busy", "the bridge has more commands arriving than it takes: try again later").dump(), 1,
        false);
}

void Bridge::take_messages() {
    std::deque<Inbound> taken;
    {
        std::lock_guard lock(mutex_);
        taken.swap(inbox_);
    }
    for (auto& m : taken) {
        carry(commander_.message(m.target, m.payload, m.retained, m.received, m.arrived));
    }
}

void Bridge::carry(const CommanderEffects& effects) {
    if (log::enabled(log::Level::Debug)) {
        for (const auto& note : effects.debug) {
            log::debug(note.text, {.bus = note.bus, .drive = note.drive});
        }
    }
    for (const auto& r : effects.results) {
        link_->publish(topics_.result(r.bus, r.drive), r.payload.dump(), 1, false);
    }
    for (const auto& s : effects.steps) {
        DriveLink* d = find(s.bus, s.drive);
        const std::uint64_t ticket = s.ticket;
        auto after = [this, ticket](const std::expected<void, Error>& done) {
            if (ticket != 0) {
                carry(commander_.done(ticket, done, Clock::now()));
            }
        };
        if (d == nullptr) {  // the Commander asks only for drives the Fleet has
            Error gone;
            gone.kind = ErrorKind::NoSuchBus;
            gone.message = "bus '" + s.bus + "' has no drive '" + s.drive + "' any more";
            after(std::unexpected(std::move(gone)));
            continue;
        }
        switch (s.action.kind) {
        case Action::Kind::Write: {
            const std::array<std::uint16_t, 1> word{s.action.raw};
            d->drive.async_write(s.action.address, word, std::move(after), write_options(s.deadline));
            break;
        }
        case Action::Kind::KeepAlive: d->drive.async_keep_alive(std::move(after)); break;
        case Action::Kind::Release: d->drive.async_release_control(std::move(after)); break;
        }
    }
}

}  // namespace drivebus::mqtt
