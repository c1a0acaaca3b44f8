// SPDX-License-Identifier: Apache-2.0
#include "mqtt/inbox.hpp"

#include <utility>

namespace drivebus::mqtt {

std::optional<Inbound> Inbox::offer(Inbound message) {
    if (waiting_.size() >= bound_) {
        return message;
    }
    waiting_.push_back(std::move(message));
    return std::nullopt;
}

std::deque<Inbound> Inbox::take() {
    std::deque<Inbound> taken;
    taken.swap(waiting_);
    return taken;
}

CommandResult refused_busy(const Inbound& message, std::size_t max_payload) {
    const auto parsed = parse_command(message.payload, max_payload);
    const Json id = parsed ? parsed->id : parsed.error().id;
    return CommandResult{
        .bus = message.target.bus,
        .drive = message.target.drive,
        .payload = result_error(id, "busy", "the bridge has more commands arriving than it takes: try again later")};
}

}  // namespace drivebus::mqtt
