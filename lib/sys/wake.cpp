// SPDX-License-Identifier: Apache-2.0
#include "sys/wake.hpp"

#include <grp.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <array>
#include <cstring>
#include <utility>

namespace drivebus::sys {
namespace {

std::expected<sockaddr_un, SysError> address_of(const std::string& path) {
    sockaddr_un addr{};
    if (path.empty() || path.size() >= sizeof(addr.sun_path)) {
        return std::unexpected(SysError{"socket path", ENAMETOOLONG});
    }
    addr.sun_family = AF_UNIX;
    std::memcpy(addr.sun_path, path.c_str(), path.size() + 1);
    return addr;
}

}  // namespace

std::string wake_socket_path(std::string_view bus) {
    return "/tmp/drivebus-" + std::string(bus) + ".wake";
}

WakeServer::WakeServer(UniqueFd listener, std::string path, std::size_t limit)
    : listener_(std::move(listener)), path_(std::move(path)), limit_(limit) {}

std::expected<WakeServer, SysError> WakeServer::listen(const std::string& path, const std::string& group,
                                                       std::size_t limit) {
    const auto addr = address_of(path);
    if (!addr) {
        return std::unexpected(addr.error());
    }
    const auto fd =
        posix_call("socket", [] { return ::socket(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0); });
    if (!fd) {
        return std::unexpected(fd.error());
    }
    UniqueFd owned(*fd);
    (void)::unlink(path.c_str());  // a socket left by a drivebusd gone (the caller checked none serves the bus)
    // Until the chown and chmod below, the umask decides who may connect (drivebusd's unit:
    // its own group): a wake-up gives nothing away, so that moment needs no closing.
    const auto bound = posix_call(
        "bind", [&] { return ::bind(owned.get(), reinterpret_cast<const sockaddr*>(&*addr), sizeof *addr); });
    if (!bound) {
        return std::unexpected(bound.error());
    }
    WakeServer server(std::move(owned), path, limit);
    if (const auto* g = group.empty() ? nullptr : ::getgrnam(group.c_str()); g != nullptr) {
        if (auto chowned =
                posix_call("chown", [&] { return ::chown(path.c_str(), static_cast<uid_t>(-1), g->gr_gid); });
            !chowned) {
            return std::unexpected(chowned.error());
        }
    }
    if (auto opened = posix_call("chmod", [&] { return ::chmod(path.c_str(), 0660); }); !opened) {
        return std::unexpected(opened.error());
    }
    if (auto listening = posix_call("listen", [&] { return ::listen(server.fd(), 64); }); !listening) {
        return std::unexpected(listening.error());
    }
    return server;
}

WakeServer::~WakeServer() {
    if (!path_.empty()) {
        (void)::unlink(path_.c_str());
    }
}

WakeServer::WakeServer(WakeServer&& other) noexcept
    : listener_(std::move(other.listener_)),
      path_(std::exchange(other.path_, {})),
      limit_(other.limit_),
      connections_(std::move(other.connections_)) {}

WakeServer& WakeServer::operator=(WakeServer&& other) noexcept {
    if (this != &other) {
        if (!path_.empty()) {
            (void)::unlink(path_.c_str());
        }
        listener_ = std::move(other.listener_);
        path_ = std::exchange(other.path_, {});
        limit_ = other.limit_;
        connections_ = std::move(other.connections_);
    }
    return *this;
}

void WakeServer::accept_waiting() {
    for (;;) {
        const auto fd = posix_call(
            "accept4", [&] { return ::accept4(listener_.get(), nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC); });
        if (!fd) {
            return;  // EAGAIN: none left; anything else: that one is gone
        }
        UniqueFd connection(*fd);
        if (connections_.size() >= limit_) {
            wake();  // closes those whose applications have gone; then there may be room
        }
        if (connections_.size() < limit_) {
            connections_.push_back(std::move(connection));
        }
    }
}

void WakeServer::wake() {
    static constexpr std::array<char, 1> kByte{1};
    std::erase_if(connections_, [](const UniqueFd& c) {
        const auto sent = ::send(c.get(), kByte.data(), kByte.size(), MSG_DONTWAIT | MSG_NOSIGNAL);
        return sent < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR;
    });
}

std::expected<UniqueFd, SysError> wake_connect(const std::string& path) {
    const auto addr = address_of(path);
    if (!addr) {
        return std::unexpected(addr.error());
    }
    const auto fd =
        posix_call("socket", [] { return ::socket(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0); });
    if (!fd) {
        return std::unexpected(fd.error());
    }
    UniqueFd owned(*fd);
    // A Unix stream socket connects at once or fails (EAGAIN only when the backlog is full).
    const auto connected = posix_call(
        "connect", [&] { return ::connect(owned.get(), reinterpret_cast<const sockaddr*>(&*addr), sizeof *addr); });
    if (!connected) {
        return std::unexpected(connected.error());
    }
    return owned;
}

bool wake_drain(int fd) noexcept {
    std::array<char, 256> bytes{};
    for (;;) {
        const auto got = ::recv(fd, bytes.data(), bytes.size(), MSG_DONTWAIT);
        if (got > 0) {
            continue;
        }
        if (got == 0) {
            return false;  // drivebusd closed its end
        }
        if (errno == EINTR) {
            continue;
        }
        return errno == EAGAIN || errno == EWOULDBLOCK;
    }
}

}  // namespace drivebus::sys
