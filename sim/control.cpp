// SPDX-License-Identifier: Apache-2.0
#include "control.hpp"

#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <array>
#include <cstring>
#include <stdexcept>

namespace drivebus::sim {

ControlServer::ControlServer(sys::EventLoop& loop, std::filesystem::path path, Handler handler)
    : loop_(loop), path_(std::move(path)), handler_(std::move(handler)) {
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    const std::string p = path_.string();
    if (p.size() >= sizeof addr.sun_path) {
        throw std::runtime_error("control socket path too long: " + p);
    }
    std::memcpy(addr.sun_path, p.c_str(), p.size() + 1);
    auto fd =
        sys::posix_call("socket", [] { return ::socket(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0); });
    if (!fd) {
        throw std::runtime_error(fd.error().message());
    }
    listener_.reset(*fd);
    std::error_code ec;
    if (std::filesystem::is_socket(path_, ec)) {
        std::filesystem::remove(path_, ec);  // left over from a simulator that was killed
    }
    const auto* sa = reinterpret_cast<const sockaddr*>(&addr);
    if (auto bound = sys::posix_call("bind", [&] { return ::bind(listener_.get(), sa, sizeof addr); }); !bound) {
        throw std::runtime_error("control socket " + p + ": " + bound.error().message());
    }
    if (auto listening = sys::posix_call("listen", [&] { return ::listen(listener_.get(), 8); }); !listening) {
        throw std::runtime_error("control socket " + p + ": " + listening.error().message());
    }
    if (auto added = loop_.add(listener_.get(), [this] { accept_client(); }); !added) {
        throw std::runtime_error("control socket " + p + ": " + added.error().message());
    }
}

ControlServer::~ControlServer() {
    for (auto& [fd, client] : clients_) {
        loop_.remove(fd);
    }
    loop_.remove(listener_.get());
    std::error_code ec;
    std::filesystem::remove(path_, ec);
}

void ControlServer::accept_client() {
    const int fd = ::accept4(listener_.get(), nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd < 0) {
        return;
    }
    clients_.emplace(fd, std::make_pair(sys::UniqueFd(fd), std::string{}));
    if (auto added = loop_.add(fd, [this, fd] { serve(fd); }); !added) {
        clients_.erase(fd);  // closes it: the client sees its command refused
    }
}

void ControlServer::drop(int fd) {
    loop_.remove(fd);
    clients_.erase(fd);
}

void ControlServer::serve(int fd) {
    std::array<char, 1024> buffer{};
    const auto n = sys::posix_call("read", [&] { return ::read(fd, buffer.data(), buffer.size()); });
    if (!n || *n == 0) {
        if (n || n.error().error != EAGAIN) {
            drop(fd);
        }
        return;
    }
    std::string& pending = clients_[fd].second;
    pending.append(buffer.data(), static_cast<std::size_t>(*n));
    if (pending.size() > 4096) {
        drop(fd);  // no command is that long
        return;
    }
    std::size_t newline = 0;
    while ((newline = pending.find('\n')) != std::string::npos) {
        std::string line = pending.substr(0, newline);
        pending.erase(0, newline + 1);
        if (!line.empty() && line.back() == '\r') {
            line.pop_back();
        }
        const std::string answer = handler_(line) + "\n";
        // Answers are short; a client that does not read them loses them.
        [[maybe_unused]] const auto w = ::write(fd, answer.data(), answer.size());
    }
}

}  // namespace drivebus::sim
