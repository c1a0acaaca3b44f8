// SPDX-License-Identifier: Apache-2.0
// Requests handed to iceoryx on a thread of their own, so that no caller waits on iceoryx past
// its time-out. iceoryx 2.0's send() takes process-shared locks that are not robust: a client
// killed inside its send() leaves them held, and every other send() then waits until someone
// frees them (drivebusd with its embedded RouDi does, within a few hundred milliseconds; an
// external iox-roudi never does). A caller that gives up takes back its request if it has not
// reached iceoryx yet; one that iceoryx holds is the sender's until send() returns.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <thread>

#include "drivebus/shm.hpp"

namespace drivebus {

class Sender {
public:
    // Called on the sender's thread once iceoryx has taken (`sent`) or refused a request; never
    // after the Sender is gone. It must not post or withdraw.
    using Done = std::function<void(const shm::Request& request, bool sent)>;
    // Hands a request to iceoryx (loan, copy, send): false when iceoryx refused it.
    using HandOver = std::function<bool(const shm::Request& request)>;

    Sender(HandOver hand_over, Done done);
    ~Sender() { (void)stop(); }
    Sender(const Sender&) = delete;
    Sender& operator=(const Sender&) = delete;
    Sender(Sender&&) = delete;
    Sender& operator=(Sender&&) = delete;

    void post(const shm::Request& request);
    // Takes back a request that has not reached iceoryx yet: true when it never will.
    bool withdraw(std::uint64_t correlation);
    // Ends the thread, Done with it. True when a send() has not returned: its thread is then
    // left to iceoryx, and the port must be left as it is, for good.
    bool stop();

private:
    // How long stop() waits for a send() under way before it leaves it to iceoryx.
    static constexpr std::chrono::seconds kSendGrace{2};
    struct State;
    static void run(const std::shared_ptr<State>& state);

    std::shared_ptr<State> state_;
    std::thread thread_;
};

}  // namespace drivebus
