// SPDX-License-Identifier: Apache-2.0
#include "gateway/session.hpp"

#include <fmt/format.h>

#include <algorithm>

#include "gateway/route.hpp"

namespace drivebus::gateway {

Session::Session(SessionLimits limits, const Directory& directory) : limits_(limits), directory_(directory) {}

void Session::open(std::uint64_t id, std::string peer, bool may_write, shm::LeaseToken none, std::int64_t now_ns) {
    Connection c;
    c.peer = std::move(peer);
    c.may_write = may_write;
    c.none = none;
    c.last_request_ns = now_ns;
    connections_.insert_or_assign(id, std::move(c));
}

void Session::close(std::uint64_t id) {
    connections_.erase(id);
    std::erase_if(turns_, [&](const Job& job) { return job.connection == id; });
    stats_.waiting = turns_.size();
}

void Session::drop(std::uint64_t id, std::string why, Effects& out) {
    close(id);
    out.closes.emplace_back(id, std::move(why));
}

Effects Session::received(std::uint64_t id, std::span<const std::uint8_t> bytes, std::int64_t now_ns) {
    Effects out;
    const auto it = connections_.find(id);
    if (it != connections_.end()) {
        it->second.reader.feed(bytes);
        pump(id, now_ns, out);
    }
    return out;
}

Effects Session::unsent(std::uint64_t id, std::size_t bytes, std::int64_t now_ns) {
    Effects out;
    const auto it = connections_.find(id);
    if (it == connections_.end()) {
        return out;
    }
    const bool held = it->second.unsent > limits_.max_unsent;
    it->second.unsent = bytes;
    // Its client read its answers: what waited behind them is taken now, even if it sends
    // nothing more (its read-ahead may be full, so nothing else would wake it).
    if (held && bytes <= limits_.max_unsent) {
        pump(id, now_ns, out);
    }
    return out;
}

bool Session::reading(std::uint64_t id) const {
    const auto it = connections_.find(id);
    return it != connections_.end() && it->second.queue.size() < limits_.max_pipelined &&
           it->second.unsent <= limits_.max_unsent;
}

void Session::pump(std::uint64_t id, std::int64_t now_ns, Effects& out) {
    for (;;) {
        const auto it = connections_.find(id);
        if (it == connections_.end()) {
            return;
        }
        Connection& c = it->second;
        // Take what has arrived, up to the read-ahead bound.
        while (c.queue.size() < limits_.max_pipelined) {
            auto next = c.reader.next();
            if (!next) {
                ++stats_.broken_streams;
                out.notes.push_back({Severity::Notice,
                                     fmt::format("gateway: {}: {}: connection closed", c.peer, to_string(next.error())),
                                     {},
                                     {}});
                drop(id, {}, out);
                return;
            }
            if (!next->has_value()) {
                break;
            }
            c.queue.push_back(std::move(**next));
            c.last_request_ns = now_ns;
            ++stats_.requests;
        }
        if (c.busy || c.queue.empty() || c.unsent > limits_.max_unsent) {
            return;
        }
        const Adu adu = std::move(c.queue.front());
        c.queue.pop_front();
        take(id, c, adu, now_ns, out);
    }
}

void Session::take(std::uint64_t id, Connection& c, const Adu& adu, std::int64_t now_ns, Effects& out) {
    const std::uint8_t fc = adu.pdu.empty() ? 0 : adu.pdu[0];
    const Route* route = directory_.route(adu.unit);
    if (route == nullptr) {
        reply(id, c, adu.transaction, adu.unit, exception_pdu(fc, Exception::GatewayPathUnavailable), out);
        return;
    }
    const auto call = parse_request(adu.pdu);
    if (!call) {
        reply(id, c, adu.transaction, adu.unit, exception_pdu(call.error().function, call.error().exception), out);
        return;
    }
    const auto snapshot = directory_.snapshot(adu.unit);
    Context context;
    context.drive = route->drive;
    context.snapshot = snapshot ? &*snapshot : nullptr;
    context.now_ns = now_ns;
    context.max_age_ns = limits_.max_age_ns;
    context.may_write = c.may_write;
    context.written = &given_[{route->bus, route->drive}];
    auto decision = decide(*call, context);
    if (auto* answer = std::get_if<Answer>(&decision)) {
        if (!answer->refused_write.empty()) {
            refused_write(c, adu.unit, std::get<WriteRegisters>(*call), answer->refused_write, out);
        }
        if (answer->from_snapshot) {
            ++stats_.from_snapshot;
        }
        reply(id, c, adu.transaction, adu.unit, answer->pdu, out);
        return;
    }
    Job job{id, adu.transaction, adu.unit, *call, std::get<Send>(decision).request};
    const auto token = c.tokens.find(route->bus);
    job.request.lease_token = token != c.tokens.end() ? token->second : c.none;
    shm::assign(job.request.client_name, "tcp " + c.peer);  // as drivebusd shows it
    c.busy = true;
    if (with_drivebusd_.size() < limits_.workers) {
        send(std::move(job), out);
    } else {
        turns_.push_back(std::move(job));  // its turn comes when one under way is answered
        stats_.waiting = turns_.size();
    }
}

void Session::send(Job job, Effects& out) {
    const std::uint64_t ticket = next_ticket_++;
    ++stats_.sent;
    out.requests.push_back({ticket, job.unit, job.request});
    with_drivebusd_.emplace(ticket, std::move(job));
}

Effects Session::answered(std::uint64_t ticket, const std::expected<shm::Response, Error>& result,
                          std::int64_t now_ns) {
    Effects out;
    const auto it = with_drivebusd_.find(ticket);
    if (it == with_drivebusd_.end()) {
        return out;
    }
    const Job job = std::move(it->second);
    with_drivebusd_.erase(it);
    // The connections waiting their turn first, in the order they came.
    while (with_drivebusd_.size() < limits_.workers && !turns_.empty()) {
        Job next = std::move(turns_.front());
        turns_.pop_front();
        send(std::move(next), out);
    }
    stats_.waiting = turns_.size();
    const auto c = connections_.find(job.connection);
    if (c == connections_.end()) {
        return out;  // closed meanwhile: a lease its write took runs out
    }
    c->second.busy = false;
    const Route* route = directory_.route(job.unit);
    if (result && result->lease_ms > 0 && result->lease_token != shm::LeaseToken{} && route != nullptr) {
        c->second.tokens[route->bus] = result->lease_token;
    }
    const auto* write = std::get_if<WriteRegisters>(&job.call);
    const auto* read = std::get_if<ReadRegisters>(&job.call);
    const bool ok = result && result->status == shm::Status::Ok;
    if (ok && route != nullptr && (write != nullptr || read != nullptr)) {
        // What the gateway has given of these registers: a snapshot older is not served after.
        std::int64_t at = result->reply_ns;
        std::uint16_t start = 0;
        std::size_t count = 0;
        if (write != nullptr) {
            at = std::max(at, now_ns);
            start = write->start;
            count = write->values.size();
        } else if (read != nullptr) {
            start = read->start;
            count = read->count;
        }
        auto& registers = given_[{route->bus, route->drive}];
        for (std::size_t i = 0; i < count; ++i) {
            auto& when = registers[static_cast<std::uint16_t>(start + i)];
            when = std::max(when, at);
        }
    } else if (write != nullptr) {
        refused_write(c->second, job.unit, *write, describe_failure(result), out);
    }
    reply(job.connection, c->second, job.transaction, job.unit, answer(job.call, result), out);
    pump(job.connection, now_ns, out);
    return out;
}

void Session::reply(std::uint64_t id, Connection& c, std::uint16_t transaction, std::uint8_t unit,
                    const std::vector<std::uint8_t>& pdu, Effects& out) {
    if (pdu.size() >= 2 && (pdu[0] & 0x80) != 0) {
        ++stats_.exceptions;
    }
    auto adu = encode(transaction, unit, pdu);
    c.unsent += adu.size();
    out.replies.emplace_back(id, std::move(adu));
}

Effects Session::tick(std::int64_t now_ns) {
    Effects out;
    // A write older than max_age no longer matters: no value that old is served anyway.
    const std::int64_t horizon = now_ns - limits_.max_age_ns;
    for (auto& [drive, registers] : given_) {
        std::erase_if(registers, [&](const auto& w) { return w.second < horizon; });
    }
    std::erase_if(given_, [](const auto& drive) { return drive.second.empty(); });
    if (limits_.idle_timeout_ns == 0) {
        return out;
    }
    std::vector<std::uint64_t> idle;
    for (const auto& [id, c] : connections_) {
        if (!c.busy && now_ns - c.last_request_ns > limits_.idle_timeout_ns) {
            idle.push_back(id);
        }
    }
    for (const auto id : idle) {
        ++stats_.idle_closed;
        drop(id, "idle: closed (idle_timeout)", out);
    }
    return out;
}

void Session::refused_write(const Connection& c, std::uint8_t unit, const WriteRegisters& write, const std::string& why,
                            Effects& out) {
    ++stats_.refused_writes;
    const Route* route = directory_.route(unit);
    out.notes.push_back(
        {Severity::Notice,
         fmt::format("gateway: write refused from {} to unit {} ({}), register 0x{:04X}, {} word(s): {}", c.peer, unit,
                     route != nullptr ? route->drive : std::string("no drive"), write.start, write.values.size(), why),
         route != nullptr ? route->bus : std::string(), route != nullptr ? route->drive : std::string()});
}

}  // namespace drivebus::gateway
