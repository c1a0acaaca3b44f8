// SPDX-License-Identifier: Apache-2.0
#include "bus.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "rtu/codec.hpp"

namespace drivebus::sim {

Bus::Bus(BusOptions options) : options_(options), rng_(options.seed) {}

void Bus::add(std::unique_ptr<ProfileDrive> drive) {
    const auto address = drive->address();
    drives_[address] = std::move(drive);
}

ProfileDrive* Bus::drive(rtu::SlaveAddress address) noexcept {
    const auto it = drives_.find(address);
    return it == drives_.end() ? nullptr : it->second.get();
}

std::vector<rtu::SlaveAddress> Bus::addresses() const {
    std::vector<rtu::SlaveAddress> out;
    for (const auto& [address, drive] : drives_) {
        out.push_back(address);
    }
    return out;
}

bool Bus::chance(double share) {
    if (share <= 0.0) {
        return false;
    }
    if (share >= 1.0) {
        return true;
    }
    return std::uniform_real_distribution<double>(0.0, 1.0)(rng_) < share;
}

void Bus::advance(rtu::Instant now) {
    for (auto& [address, drive] : drives_) {
        drive->advance(now);
    }
}

void Bus::record_silence(rtu::Duration at_least, rtu::Duration at_most) {
    const rtu::Duration silence = at_least;
    if (at_most < options_.timing.t3_5) {
        ++short_silences_;
    }
    constexpr std::size_t kKept = 1'000'000;
    if (silences_us_.size() < kKept) {
        silences_us_.push_back(std::chrono::duration<double, std::micro>(silence).count());
    }
}

std::string Bus::silence_summary() const {
    std::vector<double> s = silences_us_;
    std::sort(s.begin(), s.end());
    auto at = [&](double q) {
        if (s.empty()) {
            return 0.0;
        }
        const auto i = static_cast<std::size_t>(q * static_cast<double>(s.size() - 1) + 0.5);
        return s[i];
    };
    const auto fmt = [](double v) { return std::to_string(static_cast<long long>(std::llround(v))); };
    return "count=" + std::to_string(s.size()) + " short=" + std::to_string(short_silences_) +
           " after_slip=" + std::to_string(slips_) +
           " t35_us=" + fmt(std::chrono::duration<double, std::micro>(options_.timing.t3_5).count()) +
           " min_us=" + fmt(s.empty() ? 0.0 : s.front()) + " p50_us=" + fmt(at(0.5)) + " p99_us=" + fmt(at(0.99)) +
           " max_us=" + fmt(s.empty() ? 0.0 : s.back());
}

void Bus::on_discarded(const rtu::DiscardedFrame& /*discarded*/) {
    ++counters_.broken;
}

TxPlan Bus::on_received(std::span<const std::uint8_t> bytes, rtu::Instant last_char_end) {
    TxPlan plan;
    if (!faults_.echo()) {
        return plan;
    }
    const auto n = static_cast<std::int64_t>(bytes.size());
    for (std::int64_t i = 0; i < n; ++i) {
        plan.push_back({last_char_end - options_.timing.character * (n - 1 - i), bytes[static_cast<std::size_t>(i)]});
    }
    counters_.echoed += bytes.size();
    return plan;
}

TxPlan Bus::on_frame(const rtu::Frame& frame) {
    const auto bytes = frame.adu.bytes();
    const rtu::SlaveAddress address = bytes[0];
    const rtu::Instant end_seen = frame.last + options_.timing.t3_5;

    const auto request = rtu::decode_request(bytes);
    if (!request) {
        ProfileDrive* target = drive(address);
        const auto code = rtu::exception_for(request.error());
        // A slave answers a well-formed frame it cannot serve; broken frames get nothing.
        if (target == nullptr || address == rtu::kBroadcastAddress || !code || (bytes[1] & rtu::kExceptionFlag) != 0) {
            ++counters_.broken;
            return {};
        }
        // Function 0 has no exception reply (0x80 alone names no function): nothing to answer.
        const auto reply = rtu::encode_response({address, rtu::ExceptionResponse{bytes[1], *code}});
        if (!reply) {
            ++counters_.broken;
            return {};
        }
        target->advance(end_seen);
        ++counters_.requests;
        ++counters_.exceptions;
        const DriveFaults& faults = faults_.for_drive(address);
        return plan_reply(*reply, faults, end_seen + options_.turnaround + faults.late);
    }

    if (request->address == rtu::kBroadcastAddress) {
        ++counters_.broadcasts;
        const auto function = static_cast<std::uint8_t>(rtu::function_of(request->pdu));
        for (auto& [a, d] : drives_) {
            const auto& allowed = d->profile().functions.broadcast;
            if (std::ranges::find(allowed, function) != allowed.end()) {
                (void)d->handle(request->pdu, true, end_seen);
            }
        }
        return {};
    }

    ProfileDrive* target = drive(request->address);
    if (target == nullptr) {
        ++counters_.foreign;
        return {};
    }
    ++counters_.requests;
    const DriveFaults& faults = faults_.for_drive(request->address);
    rtu::Response response = target->handle(request->pdu, false, end_seen);

    if (chance(faults.drop)) {
        ++counters_.dropped;
        return {};
    }
    if (faults.exception) {
        ++counters_.injected_exceptions;
        response = rtu::ExceptionResponse{static_cast<std::uint8_t>(rtu::function_of(request->pdu)),
                                          static_cast<rtu::ExceptionCode>(*faults.exception)};
    }
    if (std::holds_alternative<rtu::ExceptionResponse>(response)) {
        ++counters_.exceptions;
    }
    const auto reply = rtu::encode_response({request->address, response});
    if (!reply) {
        ++counters_.broken;  // the drive built something unsendable; a real one would stay silent
        return {};
    }
    if (faults.late.count() > 0) {
        ++counters_.late;
    }
    return plan_reply(*reply, faults, end_seen + options_.turnaround + faults.late);
}

TxPlan Bus::plan_reply(const rtu::Adu& reply, const DriveFaults& faults, rtu::Instant start) {
    const rtu::Duration c = options_.pace ? options_.timing.character : rtu::Duration{0};
    const rtu::Duration real_c = options_.timing.character;
    TxPlan plan;
    const std::uint8_t address = reply.bytes()[0];
    rtu::Instant t = std::max(start, reply_end_[address] + options_.timing.t3_5);

    if (faults.noise > 0) {
        ++counters_.noise;
        std::uniform_int_distribution<int> byte(0, 255);
        for (std::size_t i = 0; i < faults.noise; ++i) {
            t += c;
            plan.push_back({t, static_cast<std::uint8_t>(byte(rng_))});
        }
        t += std::chrono::duration_cast<rtu::Duration>(real_c * faults.noise_gap_chars);
    }

    std::vector<std::uint8_t> bytes(reply.bytes().begin(), reply.bytes().end());
    if (chance(faults.crc)) {
        ++counters_.crc;
        bytes.back() ^= 0xFF;
    }
    const bool gap = faults.gap_at && *faults.gap_at < bytes.size();
    if (gap) {
        ++counters_.gap;
    }
    for (std::size_t i = 0; i < bytes.size(); ++i) {
        if (gap && i == *faults.gap_at) {
            t += std::chrono::duration_cast<rtu::Duration>(real_c * faults.gap_chars);
        }
        t += c;
        plan.push_back({t, bytes[i]});
    }
    plan.back().reply_end = true;
    reply_end_[address] = plan.back().at;
    plan.back().address = bytes[0];
    plan.back().function = bytes[1];
    ++counters_.replies;
    return plan;
}

}  // namespace drivebus::sim
