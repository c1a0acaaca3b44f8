// SPDX-License-Identifier: Apache-2.0
#include "sender.hpp"

#include <pthread.h>

#include <algorithm>

namespace drivebus {

// Shared by the Sender and its thread, which may outlive it when iceoryx never lets go.
struct Sender::State {
    std::mutex mutex;  // everything below
    std::condition_variable wake;
    std::deque<shm::Request> queue;
    bool stop = false;
    bool sending = false;  // a request is inside iceoryx's loan()/send()
    Done done;             // empty once the Sender is gone
    HandOver hand_over;
};

Sender::Sender(HandOver hand_over, Done done) : state_(std::make_shared<State>()) {
    state_->hand_over = std::move(hand_over);
    state_->done = std::move(done);
    thread_ = std::thread(run, state_);
    ::pthread_setname_np(thread_.native_handle(), "drivebus-send");
}

bool Sender::stop() {
    bool stuck = false;
    {
        std::unique_lock lock(state_->mutex);
        state_->stop = true;
        state_->done = nullptr;
        state_->queue.clear();
        // A send() under way almost always returns at once (its answer can even arrive first,
        // and the caller be gone): waited for a while. Only one iceoryx still holds then is left
        // to it; ending the process under a send() that is still running aborts in iceoryx.
        state_->wake.wait_for(lock, kSendGrace, [&] { return !state_->sending; });
        stuck = state_->sending;
    }
    state_->wake.notify_all();
    if (thread_.joinable()) {
        if (stuck) {
            thread_.detach();  // it holds the state it needs, and ends if iceoryx ever lets go
        } else {
            thread_.join();
        }
    }
    return stuck;
}

void Sender::post(const shm::Request& request) {
    {
        const std::lock_guard lock(state_->mutex);
        state_->queue.push_back(request);
    }
    state_->wake.notify_all();
}

bool Sender::withdraw(std::uint64_t correlation) {
    const std::lock_guard lock(state_->mutex);
    auto& q = state_->queue;
    const auto it = std::ranges::find_if(
        q, [&](const shm::Request& r) { return r.correlation == correlation && r.kind != shm::RequestKind::Withdraw; });
    if (it == q.end()) {
        return false;
    }
    q.erase(it);
    return true;
}

void Sender::run(const std::shared_ptr<State>& state) {
    std::unique_lock lock(state->mutex);
    for (;;) {
        state->wake.wait(lock, [&] { return state->stop || !state->queue.empty(); });
        if (state->stop) {
            return;
        }
        const shm::Request request = state->queue.front();
        state->queue.pop_front();
        state->sending = true;
        lock.unlock();
        const bool sent = state->hand_over(request);
        lock.lock();
        state->sending = false;
        state->wake.notify_all();  // a stop() may wait for this send
        if (state->done) {
            state->done(request, sent);
        }
    }
}

}  // namespace drivebus
