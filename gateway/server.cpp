// SPDX-License-Identifier: Apache-2.0
#include "gateway/server.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/random.h>
#include <sys/socket.h>
#include <unistd.h>

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstring>
#include <deque>
#include <system_error>

#include "log/log.hpp"

namespace drivebus::gateway {
namespace {

constexpr std::size_t kReadChunk = 4096;
constexpr auto kTick = std::chrono::seconds(1);
// Half-open peers (a cable pulled, a crashed host) are found by TCP keepalive: probes after 10 s
// of silence, every 5 s, given up after 3.
constexpr int kKeepIdleS = 10;
constexpr int kKeepIntervalS = 5;
constexpr int kKeepCount = 3;

std::int64_t monotonic_ns() noexcept {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(sys::now().time_since_epoch()).count();
}

shm::LeaseToken random_token() {
    shm::LeaseToken t{};
    // getrandom never returns fewer than 256 bytes from the urandom pool once it is initialised.
    if (::getrandom(t.data(), sizeof t, 0) != static_cast<ssize_t>(sizeof t) || t == shm::LeaseToken{}) {
        t[0] = static_cast<std::uint64_t>(monotonic_ns()) | 1U;
    }
    return t;
}

[[noreturn]] void fail(const std::string& what) {
    throw std::system_error(errno, std::generic_category(), what);
}

sys::UniqueFd listen_on(const Endpoint& at, std::uint16_t& bound) {
    const bool v6 = at.host.find(':') != std::string::npos || at.host.empty();
    sys::UniqueFd fd(::socket(v6 ? AF_INET6 : AF_INET, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0));
    const std::string where =
        at.host.empty() ? fmt::format("*:{}", at.port)
                        : (v6 ? fmt::format("[{}]:{}", at.host, at.port) : fmt::format("{}:{}", at.host, at.port));
    if (!fd) {
        fail("socket for " + where);
    }
    const int on = 1;
    ::setsockopt(fd.get(), SOL_SOCKET, SO_REUSEADDR, &on, sizeof on);
    sockaddr_storage address{};
    socklen_t length = 0;
    if (v6) {
        const int off = 0;  // "*" takes IPv4 peers too
        ::setsockopt(fd.get(), IPPROTO_IPV6, IPV6_V6ONLY, &off, sizeof off);
        sockaddr_in6 in{};
        in.sin6_family = AF_INET6;
        in.sin6_port = htons(at.port);
        in.sin6_addr = in6addr_any;
        if (!at.host.empty() && ::inet_pton(AF_INET6, at.host.c_str(), &in.sin6_addr) != 1) {
            fail("address " + where);
        }
        std::memcpy(&address, &in, sizeof in);
        length = sizeof in;
    } else {
        sockaddr_in in{};
        in.sin_family = AF_INET;
        in.sin_port = htons(at.port);
        if (::inet_pton(AF_INET, at.host.c_str(), &in.sin_addr) != 1) {
            fail("address " + where);
        }
        std::memcpy(&address, &in, sizeof in);
        length = sizeof in;
    }
    if (::bind(fd.get(), reinterpret_cast<const sockaddr*>(&address), length) != 0) {
        fail("bind " + where + (at.port < 1024 ? " (a port below 1024 needs CAP_NET_BIND_SERVICE)" : ""));
    }
    if (::listen(fd.get(), 64) != 0) {
        fail("listen " + where);
    }
    sockaddr_storage actual{};
    socklen_t actual_length = sizeof actual;
    ::getsockname(fd.get(), reinterpret_cast<sockaddr*>(&actual), &actual_length);
    bound = from_sockaddr(actual).port;
    return fd;
}

void tune(int fd) {
    const int on = 1;
    ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &on, sizeof on);  // an answer is one small segment
    ::setsockopt(fd, SOL_SOCKET, SO_KEEPALIVE, &on, sizeof on);
    ::setsockopt(fd, IPPROTO_TCP, TCP_KEEPIDLE, &kKeepIdleS, sizeof kKeepIdleS);
    ::setsockopt(fd, IPPROTO_TCP, TCP_KEEPINTVL, &kKeepIntervalS, sizeof kKeepIntervalS);
    ::setsockopt(fd, IPPROTO_TCP, TCP_KEEPCNT, &kKeepCount, sizeof kKeepCount);
}

bool listed(const std::vector<Network>& networks, const Address& peer) {
    return std::any_of(networks.begin(), networks.end(), [&](const Network& n) { return n.contains(peer); });
}

}  // namespace

struct Server::Connection {
    std::uint64_t id = 0;
    sys::UniqueFd fd;
    Address peer;
    std::vector<std::uint8_t> unsent;
    std::size_t sent = 0;
    bool reading = true;
    bool writing = false;
    bool peer_closed = false;
};

namespace {

SessionLimits limits_of(const Config& config) {
    SessionLimits limits;
    limits.max_pipelined = config.max_pipelined;
    limits.workers = config.workers;
    limits.max_age_ns = std::chrono::duration_cast<std::chrono::nanoseconds>(config.max_age).count();
    limits.idle_timeout_ns = std::chrono::duration_cast<std::chrono::nanoseconds>(config.idle_timeout).count();
    return limits;
}

log::Level level_of(Severity severity) noexcept {
    switch (severity) {
    case Severity::Info: return log::Level::Info;
    case Severity::Notice: return log::Level::Notice;
    case Severity::Warning: break;
    }
    return log::Level::Warning;
}

}  // namespace

Server::Server(Config config, Backend& backend)
    : config_(std::move(config)), backend_(backend), session_(limits_of(config_), backend_) {
    listener_ = listen_on(config_.listen, port_);
    auto check = [](std::expected<void, sys::SysError> ok, const char* what) {
        if (!ok) {
            throw std::system_error(ok.error().error, std::generic_category(), what);
        }
    };
    check(loop_.add(listener_.get(), [this] { accept_all(); }), "epoll: the listening socket");
    for (const int fd : backend_.descriptors()) {
        check(loop_.add(fd, [this] { backend_.dispatch(); }), "epoll: drivebusd's descriptor");
    }
    check(loop_.add(stop_.fd(), [this] { loop_.stop(); }), "epoll: the stop eventfd");
    check(loop_.add(tick_.fd(), [this] { on_tick(); }), "epoll: the idle timer");
    check(tick_.arm(sys::now() + kTick), "timerfd");
}

Server::~Server() = default;

void Server::run() {
    if (auto ok = loop_.run(); !ok) {
        throw std::system_error(ok.error().error, std::generic_category(), "epoll_wait in the gateway's loop");
    }
}

void Server::stop() noexcept {
    stop_.signal();
}

Stats Server::stats() const {
    std::lock_guard lock(mutex_);
    return stats_;
}

void Server::publish() {
    Stats now = session_.stats();
    now.connections = own_.connections;
    now.refused_connections = own_.refused_connections;
    now.open = connections_.size();
    std::lock_guard lock(mutex_);
    stats_ = now;
}

void Server::accept_all() {
    for (;;) {
        sockaddr_storage from{};
        socklen_t length = sizeof from;
        const int fd =
            ::accept4(listener_.get(), reinterpret_cast<sockaddr*>(&from), &length, SOCK_NONBLOCK | SOCK_CLOEXEC);
        if (fd < 0) {
            if (errno == EINTR || errno == ECONNABORTED) {
                continue;
            }
            if (errno == EMFILE || errno == ENFILE) {
                log::write(log::Level::Warning, "gateway: out of file descriptors: a connection waits in the backlog");
            }
            break;  // EAGAIN: all taken
        }
        auto c = std::make_unique<Connection>();
        c->fd.reset(fd);
        c->peer = from_sockaddr(from);
        const std::string peer = c->peer.to_string();
        if (!config_.allow_from.empty() && !listed(config_.allow_from, c->peer)) {
            ++own_.refused_connections;
            publish();
            log::write(log::Level::Notice, fmt::format("gateway: connection from {} refused: not in allow_from", peer));
            continue;
        }
        if (connections_.size() >= config_.max_connections) {
            ++own_.refused_connections;
            publish();
            log::write(log::Level::Warning, fmt::format("gateway: connection from {} refused: {} connections open "
                                                        "(max_connections)",
                                                        peer, connections_.size()));
            continue;
        }
        tune(fd);
        c->id = next_id_++;
        const bool may_write = listed(config_.write_from, c->peer);
        const std::uint64_t id = c->id;
        if (auto ok = loop_.add(fd, [this, id](sys::Readiness r) { on_ready(id, r); }); !ok) {
            log::write(log::Level::Warning,
                       fmt::format("gateway: connection from {} dropped: {}", peer, ok.error().message()));
            continue;
        }
        log::write(log::Level::Info,
                   fmt::format("gateway: connection from {}{}", peer, may_write ? " (may write)" : " (read-only)"));
        session_.open(id, peer, may_write, random_token(), monotonic_ns());
        connections_.emplace(id, std::move(c));
        ++own_.connections;
        publish();
    }
}

void Server::on_ready(std::uint64_t id, sys::Readiness readiness) {
    const auto it = connections_.find(id);
    if (it == connections_.end()) {
        return;
    }
    Connection& c = *it->second;
    if (readiness.writable) {
        flush(c);
        carry(session_.unsent(id, c.unsent.size() - c.sent, monotonic_ns()));
    }
    if (connections_.count(id) != 0 && readiness.readable && c.reading) {
        read_from(c);
    }
    if (connections_.count(id) == 0) {
        return;  // closed meanwhile
    }
    // Both directions are down (or the peer reset it): no answer can reach it any more. Closed
    // now even while it is not being read, or epoll would report the hang-up on every round.
    if (readiness.hung_up) {
        close(id, "hung up");
        return;
    }
    update_interest(c);
}

void Server::read_from(Connection& c) {
    std::array<std::uint8_t, kReadChunk> buffer{};
    const ssize_t n = ::recv(c.fd.get(), buffer.data(), buffer.size(), MSG_DONTWAIT);
    if (n == 0) {
        close(c.id, "closed by the client");
        return;
    }
    if (n < 0) {
        if (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) {
            close(c.id, "lost: " + std::generic_category().message(errno));
        }
        return;
    }
    carry(session_.received(c.id, std::span(buffer.data(), static_cast<std::size_t>(n)), monotonic_ns()));
}

void Server::carry(Effects effects) {
    std::deque<Effects> pending;
    pending.push_back(std::move(effects));
    while (!pending.empty()) {
        Effects e = std::move(pending.front());
        pending.pop_front();
        publish();  // the counters as they are before anything is answered
        for (const auto& note : e.notes) {
            log::write(level_of(note.severity), note.text, log::Fields{note.bus, note.drive});
        }
        for (auto& out : e.requests) {
            backend_.submit(out.unit, out.request,
                            [this, ticket = out.ticket](std::expected<shm::Response, Error> result) {
                                carry(session_.answered(ticket, result, monotonic_ns()));
                            });
        }
        // The answers first (a connection closed below still gets those before it), in order.
        std::vector<std::uint64_t> written;
        for (auto& [id, adu] : e.replies) {
            const auto it = connections_.find(id);
            if (it == connections_.end()) {
                continue;
            }
            Connection& c = *it->second;
            c.unsent.insert(c.unsent.end(), adu.begin(), adu.end());
            flush(c);
            if (written.empty() || written.back() != id) {
                written.push_back(id);
            }
        }
        for (const auto& [id, why] : e.closes) {
            close_socket(id, why);
        }
        for (const auto id : written) {
            const auto it = connections_.find(id);
            if (it == connections_.end()) {
                continue;
            }
            Connection& c = *it->second;
            pending.push_back(session_.unsent(id, c.unsent.size() - c.sent, monotonic_ns()));
            update_interest(c);
        }
    }
}

void Server::flush(Connection& c) {
    while (c.sent < c.unsent.size()) {
        const ssize_t n =
            ::send(c.fd.get(), c.unsent.data() + c.sent, c.unsent.size() - c.sent, MSG_DONTWAIT | MSG_NOSIGNAL);
        if (n < 0) {
            if (errno == EINTR) {
                continue;
            }
            if (errno != EAGAIN && errno != EWOULDBLOCK) {
                // The peer reset the connection: its next readiness reports the hang-up.
                c.sent = c.unsent.size();
                c.peer_closed = true;
            }
            break;
        }
        c.sent += static_cast<std::size_t>(n);
    }
    if (c.sent == c.unsent.size()) {
        c.unsent.clear();
        c.sent = 0;
    }
}

void Server::update_interest(Connection& c) {
    if (c.peer_closed) {
        close(c.id, "reset by the client");
        return;
    }
    const bool reading = session_.reading(c.id);
    const bool writing = c.sent < c.unsent.size();
    if (reading != c.reading || writing != c.writing) {
        c.reading = reading;
        c.writing = writing;
        (void)loop_.watch(c.fd.get(), reading, writing);
    }
}

void Server::close(std::uint64_t id, const std::string& why) {
    session_.close(id);
    close_socket(id, why);
}

void Server::close_socket(std::uint64_t id, const std::string& why) {
    const auto it = connections_.find(id);
    if (it == connections_.end()) {
        return;
    }
    loop_.remove(it->second->fd.get());
    if (!why.empty()) {
        log::write(log::Level::Info, fmt::format("gateway: {}: connection {}", it->second->peer.to_string(), why));
    }
    connections_.erase(it);
    publish();
}

void Server::on_tick() {
    tick_.acknowledge();
    (void)tick_.arm(sys::now() + kTick);
    carry(session_.tick(monotonic_ns()));
}

}  // namespace drivebus::gateway
