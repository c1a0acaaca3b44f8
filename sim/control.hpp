// SPDX-License-Identifier: Apache-2.0
// The control socket: a Unix stream socket taking one command per line and answering one line
// per command ("ok ..." or "error: ..."). See docs/simulator.md for the commands.
#pragma once

#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <string_view>

#include "sys/event_loop.hpp"

namespace drivebus::sim {

class ControlServer {
public:
    using Handler = std::function<std::string(std::string_view command)>;

    ControlServer(sys::EventLoop& loop, std::filesystem::path path, Handler handler);
    ~ControlServer();
    ControlServer(const ControlServer&) = delete;
    ControlServer& operator=(const ControlServer&) = delete;
    ControlServer(ControlServer&&) = delete;
    ControlServer& operator=(ControlServer&&) = delete;

private:
    void accept_client();
    void serve(int fd);
    void drop(int fd);

    sys::EventLoop& loop_;
    std::filesystem::path path_;
    Handler handler_;
    sys::UniqueFd listener_;
    std::map<int, std::pair<sys::UniqueFd, std::string>> clients_;  // fd, pending partial line
};

}  // namespace drivebus::sim
