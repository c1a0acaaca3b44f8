// SPDX-License-Identifier: Apache-2.0
// The command messages the broker's network thread hands to the bridge's loop, bounded: the
// Commander's own queue (command_queue) and as many again arriving at once, plus 16. Past the
// bound a message is given back, and refused as busy at once, its payload read no further than
// its id. Pure: the bridge (mqtt/bridge.cpp) holds its lock around it and publishes the refusals;
// tests/mqtt/relay_test.cpp floods it.
#pragma once

#include <chrono>
#include <cstddef>
#include <deque>
#include <optional>
#include <string>

#include "mqtt/commander.hpp"
#include "mqtt/freshness.hpp"
#include "mqtt/topics.hpp"

namespace drivebus::mqtt {

// A message on a set topic, as the network thread took it.
struct Inbound {
    Topics::Target target;
    std::string payload;
    bool retained = false;
    WallTime received;                              // the wall clock when it arrived: its sent_at is compared with this
    std::chrono::steady_clock::time_point arrived;  // the same moment on the steady clock: its wait counts from this
};

class Inbox {
public:
    explicit Inbox(std::size_t command_queue) : bound_(2 * command_queue + 16) {}

    // Keeps the message, or gives it back when `bound()` wait already.
    [[nodiscard]] std::optional<Inbound> offer(Inbound message);
    // Everything waiting, in the order it came; the inbox is empty after.
    [[nodiscard]] std::deque<Inbound> take();
    [[nodiscard]] std::size_t bound() const noexcept { return bound_; }
    [[nodiscard]] std::size_t size() const noexcept { return waiting_.size(); }

private:
    std::size_t bound_;
    std::deque<Inbound> waiting_;
};

// The result for a message the inbox gave back: "busy", with the command's id when the payload
// (at most `max_payload` bytes read) has one.
[[nodiscard]] CommandResult refused_busy(const Inbound& message, std::size_t max_payload);

}  // namespace drivebus::mqtt
