// SPDX-License-Identifier: Apache-2.0
// Wake-ups for applications on their own event loop. iceoryx 2.0 wakes a waiting subscriber
// through a semaphore in shared memory, which no poll() can wait on; so drivebusd also keeps a
// Unix stream socket per bus and, each time it has published or answered something, sends one
// byte to every application connected to it. An application polls its end of the connection,
// and on a wake-up takes what shared memory holds (libdrivebus's Delivery::Dispatch). A
// wake-up carries nothing else: what it announces is read from shared memory, as before.
#pragma once

#include <sys/types.h>

#include <cstddef>
#include <expected>
#include <string>
#include <string_view>
#include <vector>

#include "sys/posix.hpp"

namespace drivebus::sys {

// Where drivebusd listens for bus `bus`'s wake-ups: in /tmp beside iceoryx's own socket
// (/tmp/roudi), so whoever reaches RouDi reaches it too.
[[nodiscard]] std::string wake_socket_path(std::string_view bus);

// drivebusd's end: the listening socket and its connections. One thread (the bus's ipc thread).
class WakeServer {
public:
    // Listens at `path`, taking the place of a socket left there by a drivebusd gone. `group`:
    // who may connect (mode 0660, that group); empty, or a group that does not exist: this
    // process's own. `limit`: the most connections held; more are closed at once (their
    // applications then poll on a timer).
    static std::expected<WakeServer, SysError> listen(const std::string& path, const std::string& group,
                                                      std::size_t limit);
    ~WakeServer();
    WakeServer(WakeServer&& other) noexcept;
    WakeServer& operator=(WakeServer&& other) noexcept;
    WakeServer(const WakeServer&) = delete;
    WakeServer& operator=(const WakeServer&) = delete;

    // Readable when applications wait to connect: then call accept_waiting().
    [[nodiscard]] int fd() const noexcept { return listener_.get(); }
    void accept_waiting();
    // One byte to every connection, never blocking: a full connection has a wake-up waiting
    // already. A connection whose application has gone is closed.
    void wake();
    [[nodiscard]] std::size_t connections() const noexcept { return connections_.size(); }

private:
    WakeServer(UniqueFd listener, std::string path, std::size_t limit);
    UniqueFd listener_;
    std::string path_;  // empty: moved from
    std::size_t limit_ = 0;
    std::vector<UniqueFd> connections_;
};

// An application's end: connected and non-blocking. Fails as connect() does (ENOENT: no
// drivebusd serves that bus, EACCES: not in its group, ECONNREFUSED: a socket left behind).
[[nodiscard]] std::expected<UniqueFd, SysError> wake_connect(const std::string& path);
// Takes every wake-up waiting on an application's end: false once drivebusd has closed its end
// (it stopped, or a reload dropped the bus).
[[nodiscard]] bool wake_drain(int fd) noexcept;

}  // namespace drivebus::sys
