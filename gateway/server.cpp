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
#include <system_error>

#include "gateway/route.hpp"
#include "log/log.hpp"

namespace drivebus::gateway {
namespace {

constexpr std::size_t kReadChunk = 4096;
constexpr std::size_t kMaxUnsent = 64 * 1024;
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
    std::string name;  // as drivebusd shows it: "tcp 10.0.0.5:50122"
    bool may_write = false;
    MbapReader reader;
    std::deque<Adu> queue;  // taken, not answered; the head is with a worker while `busy`
    bool busy = false;
    std::vector<std::uint8_t> unsent;
    std::size_t sent = 0;
    std::chrono::steady_clock::time_point last_request;
    // The control leases this connection holds, by bus; `none` (random, no lease has it) is
    // presented where it holds none, so that drivebusd never takes it for another's.
    std::map<std::string, shm::LeaseToken, std::less<>> tokens;
    shm::LeaseToken none = random_token();
    bool reading = true;
    bool writing = false;
    bool peer_closed = false;
};

Server::Server(Config config, Backend& backend) : config_(std::move(config)), backend_(backend) {
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
            return;  // EAGAIN: all taken
        }
        auto c = std::make_unique<Connection>();
        c->fd.reset(fd);
        c->peer = from_sockaddr(from);
        const std::string peer = c->peer.to_string();
        if (!config_.allow_from.empty() && !listed(config_.allow_from, c->peer)) {
            bump(&Stats::refused_connections);
            log::write(log::Level::Notice, fmt::format("gateway: connection from {} refused: not in allow_from", peer));
            continue;
        }
        if (connections_.size() >= config_.max_connections) {
            bump(&Stats::refused_connections);
            log::write(log::Level::Warning, fmt::format("gateway: connection from {} refused: {} connections open "
                                                        "(max_connections)",
                                                        peer, connections_.size()));
            continue;
        }
        tune(fd);
        c->id = next_id_++;
        c->name = "tcp " + peer;
        c->may_write = listed(config_.write_from, c->peer);
        c->last_request = std::chrono::steady_clock::now();
        const std::uint64_t id = c->id;
        if (auto ok = loop_.add(fd, [this, id](sys::Readiness r) { on_ready(id, r); }); !ok) {
            log::write(log::Level::Warning,
                       fmt::format("gateway: connection from {} dropped: {}", peer, ok.error().message()));
            continue;
        }
        log::write(log::Level::Info,
                   fmt::format("gateway: connection from {}{}", peer, c->may_write ? " (may write)" : " (read-only)"));
        connections_.emplace(id, std::move(c));
        bump(&Stats::connections);
        set_open();
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
    }
    if (readiness.readable && c.reading) {
        read_from(c);
    }
    if (connections_.count(id) == 0) {
        return;  // closed by read_from
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
            close(c.id, ("lost: " + std::generic_category().message(errno)).c_str());
        }
        return;
    }
    c.reader.feed(std::span(buffer.data(), static_cast<std::size_t>(n)));
    pump(c);
}

void Server::pump(Connection& c) {
    const std::uint64_t id = c.id;
    for (;;) {
        // Take what has arrived, up to the read-ahead bound.
        while (c.queue.size() < config_.max_pipelined) {
            auto next = c.reader.next();
            if (!next) {
                bump(&Stats::broken_streams);
                log::write(log::Level::Notice, fmt::format("gateway: {}: {}: connection closed", c.peer.to_string(),
                                                           to_string(next.error())));
                close(id, nullptr);
                return;
            }
            if (!next->has_value()) {
                break;
            }
            c.queue.push_back(std::move(**next));
            c.last_request = std::chrono::steady_clock::now();
            bump(&Stats::requests);
        }
        if (c.busy || c.queue.empty() || c.unsent.size() - c.sent > kMaxUnsent) {
            return;
        }
        const Adu adu = std::move(c.queue.front());
        c.queue.pop_front();
        take(c, adu);
        if (connections_.count(id) == 0) {
            return;
        }
    }
}

void Server::take(Connection& c, const Adu& adu) {
    const std::uint8_t fc = adu.pdu.empty() ? 0 : adu.pdu[0];
    const Route* route = backend_.route(adu.unit);
    if (route == nullptr) {
        reply(c, adu.transaction, adu.unit, exception_pdu(fc, Exception::GatewayPathUnavailable));
        return;
    }
    const auto call = parse_request(adu.pdu);
    if (!call) {
        reply(c, adu.transaction, adu.unit, exception_pdu(call.error().function, call.error().exception));
        return;
    }
    const auto snapshot = backend_.snapshot(adu.unit);
    Context context;
    context.drive = route->drive;
    context.snapshot = snapshot ? &*snapshot : nullptr;
    context.now_ns = monotonic_ns();
    context.max_age_ns = std::chrono::duration_cast<std::chrono::nanoseconds>(config_.max_age).count();
    context.may_write = c.may_write;
    context.written = &written_[{route->bus, route->drive}];
    auto decision = decide(*call, context);
    if (auto* answer = std::get_if<Answer>(&decision)) {
        if (!answer->refused_write.empty()) {
            log_refused_write(c, adu.unit, std::get<WriteRegisters>(*call), answer->refused_write);
        }
        if (answer->from_snapshot) {
            bump(&Stats::from_snapshot);
        }
        reply(c, adu.transaction, adu.unit, answer->pdu);
        return;
    }
    Job job{c.id, adu.transaction, adu.unit, *call, std::get<Send>(decision).request};
    const auto token = c.tokens.find(route->bus);
    job.request.lease_token = token != c.tokens.end() ? token->second : c.none;
    shm::assign(job.request.client_name, c.name);
    c.busy = true;
    if (in_flight_ < config_.workers) {
        send(std::move(job));
    } else {
        turns_.push_back(std::move(job));  // its turn comes when one under way is answered
        set_waiting();
    }
}

void Server::send(Job job) {
    ++in_flight_;
    bump(&Stats::sent);
    const std::uint8_t unit = job.unit;
    const shm::Request request = job.request;
    backend_.submit(unit, request, [this, job = std::move(job)](std::expected<shm::Response, Error> result) {
        on_done(Done{job, std::move(result)});
    });
}

void Server::on_done(Done d) {
    --in_flight_;
    // The connections waiting their turn first, in the order they came.
    while (in_flight_ < config_.workers && !turns_.empty()) {
        Job next = std::move(turns_.front());
        turns_.pop_front();
        if (connections_.contains(next.connection)) {
            send(std::move(next));
        }
    }
    set_waiting();
    {
        const auto it = connections_.find(d.job.connection);
        if (it == connections_.end()) {
            return;  // closed meanwhile: a lease its write took runs out
        }
        Connection& c = *it->second;
        c.busy = false;
        if (d.result && d.result->lease_ms > 0 && d.result->lease_token != shm::LeaseToken{}) {
            if (const Route* route = backend_.route(d.job.unit)) {
                c.tokens[route->bus] = d.result->lease_token;
            }
        }
        const auto* write = std::get_if<WriteRegisters>(&d.job.call);
        const Route* route = backend_.route(d.job.unit);
        if (write != nullptr && d.result && d.result->status == shm::Status::Ok && route != nullptr) {
            const std::int64_t at = std::max(d.result->reply_ns, monotonic_ns());
            auto& registers = written_[{route->bus, route->drive}];
            for (std::size_t i = 0; i < write->values.size(); ++i) {
                registers[static_cast<std::uint16_t>(write->start + i)] = at;
            }
        } else if (write != nullptr) {
            log_refused_write(c, d.job.unit, *write, describe_failure(d.result));
        }
        reply(c, d.job.transaction, d.job.unit, answer(d.job.call, d.result));
        if (connections_.count(d.job.connection) == 0) {
            return;
        }
        pump(c);
        if (connections_.count(d.job.connection) != 0) {
            update_interest(c);
        }
    }
}

void Server::reply(Connection& c, std::uint16_t transaction, std::uint8_t unit, const std::vector<std::uint8_t>& pdu) {
    if (pdu.size() >= 2 && (pdu[0] & 0x80) != 0) {
        bump(&Stats::exceptions);
    }
    const auto adu = encode(transaction, unit, pdu);
    if (c.sent == c.unsent.size()) {
        c.unsent.clear();
        c.sent = 0;
    }
    c.unsent.insert(c.unsent.end(), adu.begin(), adu.end());
    flush(c);
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
    const std::size_t unsent = c.unsent.size() - c.sent;
    const bool reading = c.queue.size() < config_.max_pipelined && unsent <= kMaxUnsent;
    const bool writing = unsent > 0;
    if (reading != c.reading || writing != c.writing) {
        c.reading = reading;
        c.writing = writing;
        (void)loop_.watch(c.fd.get(), reading, writing);
    }
}

void Server::close(std::uint64_t id, const char* why) {
    const auto it = connections_.find(id);
    if (it == connections_.end()) {
        return;
    }
    loop_.remove(it->second->fd.get());
    if (why != nullptr) {
        log::write(log::Level::Info, fmt::format("gateway: {}: connection {}", it->second->peer.to_string(), why));
    }
    connections_.erase(it);
    set_open();
}

void Server::bump(std::uint64_t Stats::* field) {
    std::lock_guard lock(mutex_);
    ++(stats_.*field);
}

void Server::set_open() {
    std::lock_guard lock(mutex_);
    stats_.open = connections_.size();
}

void Server::set_waiting() {
    std::lock_guard lock(mutex_);
    stats_.waiting = turns_.size();
}

void Server::on_tick() {
    tick_.acknowledge();
    (void)tick_.arm(sys::now() + kTick);
    // A write older than max_age no longer matters: no value that old is served anyway.
    const std::int64_t horizon =
        monotonic_ns() - std::chrono::duration_cast<std::chrono::nanoseconds>(config_.max_age).count();
    for (auto& [drive, registers] : written_) {
        std::erase_if(registers, [&](const auto& w) { return w.second < horizon; });
    }
    if (config_.idle_timeout.count() == 0) {
        return;
    }
    const auto now = std::chrono::steady_clock::now();
    std::vector<std::uint64_t> idle;
    for (const auto& [id, c] : connections_) {
        if (!c->busy && now - c->last_request > config_.idle_timeout) {
            idle.push_back(id);
        }
    }
    for (const auto id : idle) {
        bump(&Stats::idle_closed);
        close(id, "idle: closed (idle_timeout)");
    }
}

void Server::log_refused_write(const Connection& c, std::uint8_t unit, const WriteRegisters& write,
                               const std::string& why) {
    bump(&Stats::refused_writes);
    const Route* route = backend_.route(unit);
    log::write(log::Level::Notice,
               fmt::format("gateway: write refused from {} to unit {} ({}), register 0x{:04X}, {} word(s): {}",
                           c.peer.to_string(), unit, route != nullptr ? route->drive : std::string("no drive"),
                           write.start, write.values.size(), why),
               log::Fields{route != nullptr ? std::string_view(route->bus) : std::string_view(),
                           route != nullptr ? std::string_view(route->drive) : std::string_view()});
}

}  // namespace drivebus::gateway
