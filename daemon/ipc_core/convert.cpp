// SPDX-License-Identifier: Apache-2.0
#include "ipc/convert.hpp"

#include <algorithm>
#include <chrono>
#include <limits>
#include <numeric>

namespace drivebus::ipc {
namespace {

template <typename T>
std::int64_t ns(T d) noexcept {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(d).count();
}

std::uint64_t sum(const std::array<std::uint64_t, 12>& a) noexcept {
    return std::accumulate(a.begin(), a.end(), std::uint64_t{0});
}

shm::Timing timing(const master::TimingStats& t) noexcept {
    return {t.count, ns(t.mean()), ns(t.max)};
}

}  // namespace

std::int64_t monotonic_ns(rtu::Instant t) noexcept {
    return ns(t.time_since_epoch());
}

shm::DriveHealth to_shm(master::Health health) noexcept {
    switch (health) {
    case master::Health::Online: return shm::DriveHealth::Online;
    case master::Health::Absent: return shm::DriveHealth::Absent;
    case master::Health::Unconfigured: return shm::DriveHealth::Unconfigured;
    case master::Health::AwaitingReset: return shm::DriveHealth::AwaitingReset;
    case master::Health::Unknown: break;
    }
    return shm::DriveHealth::Unknown;
}

shm::CommTimeout to_shm(const master::CommTimeoutNote& note) noexcept {
    // The two enums list the same cases in the same order.
    static_assert(static_cast<int>(master::CommTimeoutNote::State::ReadBack) ==
                  static_cast<int>(shm::CommTimeoutState::ReadBack));
    static_assert(static_cast<int>(master::CommTimeoutNote::Verdict::MayFire) ==
                  static_cast<int>(shm::CommTimeoutVerdict::MayFire));
    shm::CommTimeout out;
    out.state = static_cast<shm::CommTimeoutState>(note.state);
    out.verdict = static_cast<shm::CommTimeoutVerdict>(note.verdict);
    out.exception = note.exception;
    out.action_valid = note.action_read ? 1 : 0;
    out.raw = note.raw;
    out.action = note.action;
    out.timeout_ms = note.timeout_ms;
    out.wanted_ms = note.wanted_ms;
    out.gap_ms =
        note.gap ? static_cast<std::uint32_t>(std::chrono::duration_cast<std::chrono::milliseconds>(*note.gap).count())
                 : 0;
    return out;
}

void fill_snapshot(const master::DriveSnapshot& in, const Publication& publication, shm::DriveSnapshot& out) noexcept {
    out.version = shm::kPayloadVersion;
    out.size = sizeof(shm::DriveSnapshot);
    out.sequence = in.sequence;
    out.published_ns = publication.published_ns;
    shm::assign(out.bus, in.bus);
    shm::assign(out.name, in.name);
    shm::assign(out.profile, in.profile);
    out.address = in.address;
    out.health = to_shm(in.health);
    const auto& c = in.counters;
    // By name, every field: shm::DriveCounters gaining one fails the assertion until it is copied.
    static_assert(sizeof(shm::DriveCounters) == 8 * sizeof(std::uint64_t), "copy every shm::DriveCounters field");
    out.counters.requests = c.requests;
    out.counters.replies = c.replies;
    out.counters.timeouts = c.timeouts;
    out.counters.bad_frames = c.bad_frames;
    out.counters.retries = c.retries;
    out.counters.exceptions = sum(c.exceptions);
    out.counters.absent_transitions = c.absent_transitions;
    out.counters.late = c.late;
    std::size_t n = 0;
    for (const auto& [address, v] : in.registers) {  // std::map: sorted by address
        if (n == out.registers.size()) {
            break;
        }
        out.registers[n++] = {address, v.value, static_cast<std::uint8_t>(v.valid ? 1 : 0), {}, monotonic_ns(v.time)};
    }
    out.register_count = static_cast<std::uint16_t>(n);
    std::fill(out.registers.begin() + static_cast<std::ptrdiff_t>(n), out.registers.end(), shm::RegisterSample{});
    out.comm_timeout = to_shm(in.comm_timeout);
}

void fill_status(const config::BusConfig& bus, const master::BusStatus& in, const std::vector<shm::DriveHealth>& health,
                 const Publication& publication, shm::BusStatus& out) noexcept {
    out = shm::BusStatus{};
    out.size = sizeof(shm::BusStatus);
    out.sequence = in.sequence;
    out.published_ns = publication.published_ns;
    out.daemon_pid = publication.daemon_pid;
    out.baud = bus.format.baud;
    shm::assign(out.bus, bus.name);
    shm::assign(out.device, bus.device.string());
    const char parity = bus.format.parity == rtu::Parity::Even  ? 'E'
                        : bus.format.parity == rtu::Parity::Odd ? 'O'
                                                                : 'N';
    const char format[4] = {static_cast<char>('0' + bus.format.data_bits), parity,
                            static_cast<char>('0' + bus.format.stop_bits), '\0'};
    shm::assign(out.format, format);
    out.up = in.up ? 1 : 0;
    const auto& c = in.counters;
    // By name: a counter of the bus thread that shm::BusCounters lacks does not compile.
#define DRIVEBUS_COPY_COUNTER(name) out.counters.name = c.name;
    DRIVEBUS_MASTER_BUS_COUNTERS(DRIVEBUS_COPY_COUNTER)
#undef DRIVEBUS_COPY_COUNTER
    out.counters.exceptions = sum(c.exceptions);
    out.reply_latency = timing(in.reply_latency);
    out.extra_gap = timing(in.extra_gap);
    const auto n = std::min(bus.drives.size(), out.drives.size());
    out.drive_count = static_cast<std::uint8_t>(n);
    for (std::size_t i = 0; i < n; ++i) {
        auto& e = out.drives[i];
        shm::assign(e.name, bus.drives[i].name);
        shm::assign(e.profile, bus.drives[i].profile ? bus.drives[i].profile->type : "");
        e.address = bus.drives[i].address;
        e.health = i < health.size() ? health[i] : shm::DriveHealth::Unknown;
        if (e.health == shm::DriveHealth::Online) {
            ++out.drives_online;
        }
    }
}

void fill_response(const master::Finished& f, shm::Response& out) noexcept {
    switch (f.refusal) {
    case master::Refusal::None: break;
    case master::Refusal::QueueFull: out.status = shm::Status::QueueFull; return;
    case master::Refusal::BusDown: out.status = shm::Status::BusDown; return;
    case master::Refusal::Withdrawn: out.status = shm::Status::Withdrawn; return;
    case master::Refusal::Expired: out.status = shm::Status::Expired; return;
    case master::Refusal::NotWithdrawn: out.status = shm::Status::Sent; return;
    case master::Refusal::UnknownDrive:
        out.status = shm::Status::Rejected;
        out.reason = shm::RejectReason::UnknownDrive;
        return;
    case master::Refusal::BlockUnconfirmed:
        out.status = shm::Status::Rejected;
        out.reason = shm::RejectReason::BlockNotApplied;
        return;
    }
    out.attempts = f.attempts;
    out.reply_ns = monotonic_ns(f.finished);
    switch (f.outcome) {
    case master::Outcome::Ok: out.status = shm::Status::Ok; break;
    case master::Outcome::Exception: out.status = shm::Status::Exception; break;
    case master::Outcome::Timeout: out.status = shm::Status::Timeout; break;
    case master::Outcome::BadFrame:
    case master::Outcome::EchoMismatch: out.status = shm::Status::BadFrame; break;
    case master::Outcome::BusDown: out.status = shm::Status::BusDown; break;
    case master::Outcome::Expired: out.status = shm::Status::Expired; break;
    case master::Outcome::Late:
        out.status = shm::Status::Late;
        out.late_us = static_cast<std::uint32_t>(
            std::min<std::int64_t>(ns(f.late_latency) / 1000, std::numeric_limits<std::uint32_t>::max()));
        break;
    }
    if (f.exception != 0) {
        out.status = shm::Status::Exception;
        out.exception = f.exception;
        return;
    }
    const auto words = f.words.words();
    out.count = static_cast<std::uint16_t>(std::min(words.size(), out.values.size()));
    std::copy_n(words.begin(), out.count, out.values.begin());
    for (std::size_t i = 0; i < out.identity.size(); ++i) {
        shm::assign(out.identity.at(i), std::string_view(f.identity.at(i).data()));
    }
}

void fill_response(const master::Result& result, shm::Response& out) noexcept {
    fill_response(master::finished(0, result), out);
}

}  // namespace drivebus::ipc
