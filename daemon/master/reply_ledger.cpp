// SPDX-License-Identifier: Apache-2.0
#include "master/reply_ledger.hpp"

#include <algorithm>

#include "drivebus/profile.hpp"
#include "rtu/codec.hpp"

namespace drivebus::master {

bool confusable(const rtu::Request& a, const rtu::Request& b) noexcept {
    if (a.index() != b.index()) {
        return false;  // the reply's function code differs
    }
    if (const auto* ra = std::get_if<rtu::ReadHoldingRegisters>(&a)) {
        return ra->quantity == std::get<rtu::ReadHoldingRegisters>(b).quantity;
    }
    if (const auto* wa = std::get_if<rtu::WriteSingleRegister>(&a)) {
        return *wa == std::get<rtu::WriteSingleRegister>(b);  // the reply echoes address and value
    }
    if (const auto* wa = std::get_if<rtu::WriteMultipleRegisters>(&a)) {
        const auto& wb = std::get<rtu::WriteMultipleRegisters>(b);
        return wa->start == wb.start && wa->values.size() == wb.values.size();  // start and quantity
    }
    return std::get<rtu::ReadDeviceIdentification>(a).code == std::get<rtu::ReadDeviceIdentification>(b).code;
}

std::vector<rtu::Request> sync_probes(const Profile& profile, const rtu::FunctionLimits& limits) {
    std::vector<rtu::Request> candidates;
    if (profile.functions.device_identification) {
        for (const auto code : {rtu::DeviceIdCode::Basic, rtu::DeviceIdCode::Regular, rtu::DeviceIdCode::Extended}) {
            candidates.emplace_back(rtu::ReadDeviceIdentification{code, 0});
        }
    }
    std::vector<std::uint16_t> readable;
    for (const RegisterInfo& r : profile.registers) {
        if (r.address && drivebus::readable(r.access)) {
            readable.push_back(*r.address);
        }
    }
    std::ranges::sort(readable);
    for (std::uint16_t quantity = 1; quantity <= 3; ++quantity) {
        for (std::size_t i = 0; i + quantity <= readable.size(); ++i) {
            if (readable[i + quantity - 1] - readable[i] != quantity - 1) {
                continue;  // not in a row
            }
            const rtu::Request read = rtu::ReadHoldingRegisters{readable[i], quantity};
            if (rtu::encode_request({1, read}, limits)) {
                candidates.push_back(read);
                break;
            }
        }
    }
    std::erase_if(candidates, [&](const rtu::Request& r) { return !rtu::encode_request({1, r}, limits); });
    return candidates;
}

void ReplyLedger::sent(rtu::SlaveAddress address, std::uint64_t transaction, const rtu::Request& request,
                       rtu::Instant now) {
    auto& owed = slaves_[address];
    if (owed.capacity() == 0) {
        owed.reserve(kCapacity);  // once per slave: the bus thread does not allocate after that
    }
    if (owed.size() == kCapacity) {
        owed.erase(owed.begin());
    }
    owed.push_back({transaction, request, now});
}

ReplyLedger::Match ReplyLedger::received(rtu::SlaveAddress address, std::span<const std::uint8_t> adu,
                                         std::uint64_t transaction) {
    auto& owed = slaves_[address];
    for (auto it = owed.begin(); it != owed.end(); ++it) {
        if (!rtu::decode_response({address, it->request}, adu)) {
            continue;
        }
        const bool current = it->transaction == transaction && transaction != 0;
        owed.erase(owed.begin(), std::next(it));
        return current ? Match::Current : Match::Earlier;
    }
    return Match::None;
}

void ReplyLedger::forget(rtu::SlaveAddress address, rtu::Instant now, rtu::Duration forget) {
    std::erase_if(slaves_[address], [&](const Owed& o) { return now - o.sent > forget; });
}

bool ReplyLedger::in_doubt(rtu::SlaveAddress address, const rtu::Request& request) const noexcept {
    return std::ranges::any_of(slaves_[address], [&](const Owed& o) { return confusable(o.request, request); });
}

std::optional<rtu::Request> ReplyLedger::choose_probe(rtu::SlaveAddress address, std::span<const rtu::Request> probes,
                                                      const rtu::Request& next) const {
    std::optional<rtu::Request> owed_shape;
    for (const rtu::Request& probe : probes) {
        if (confusable(probe, next)) {
            continue;
        }
        if (!in_doubt(address, probe)) {
            return probe;
        }
        if (!owed_shape) {
            owed_shape = probe;
        }
    }
    // Every shape is owed: a probe of an owed shape still proves the slave in step, more slowly.
    // Its reply is matched to the oldest owed attempt it can answer, so it is taken for the
    // probe's own only once nothing older can be answered by it; until then the probe fails and
    // the request goes unsent, and each reply that comes settles what is older than it.
    return owed_shape;
}

}  // namespace drivebus::master
