// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: the simulator's line and drive models (sim::Bus::on_frame) on arbitrary
// frames, an Altivar 21 at address 1 and an Altivar 58 at address 2 with the shipped profiles.
// Input: records [flags][length][bytes...]; the target appends the CRC (the framer hands
// on_frame only frames with a good one) and lets (flags >> 1) x 10 ms pass before each, so
// ramps and the ATV21's Modbus time-out run too. Checks: a reply comes only from the addressed
// drive, never to a broadcast, after the request's end + t3.5 + turnaround, paced, with a good
// CRC, and is a reply the master would frame and decode for that request; an accepted write
// touched only registers the profile lets a master write, with values in range, and is in the
// write log; an accepted read only readable registers.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <variant>

#include "bus.hpp"
#include "fuzz_support.hpp"
#include "rtu/codec.hpp"
#include "rtu/crc.hpp"

using namespace drivebus;
using namespace std::chrono_literals;
using fuzz::check;

namespace {

const rtu::CharacterTiming kTiming = rtu::character_timing({19200, 8, rtu::Parity::None, 1}).value();
constexpr rtu::Duration kTurnaround = 1ms;

bool in_block(const Profile& p, std::uint8_t function, std::uint16_t start, std::size_t count) {
    const auto* block = p.block(function);
    return block != nullptr && block->address == start && count >= block->min_quantity && count <= block->max_quantity;
}

void check_access(const Profile& p, std::uint8_t function, std::uint16_t start, std::span<const std::uint16_t> values,
                  std::size_t count) {
    if (in_block(p, function, start, count)) {
        return;
    }
    for (std::size_t i = 0; i < count; ++i) {
        const auto* r = p.find(static_cast<std::uint16_t>(start + i));
        check(r != nullptr && r->address.has_value(), "the simulator served a register its profile lacks");
        if (values.empty()) {
            check(readable(r->access), "the simulator read a write-only register");
        } else {
            check(writable(r->access) && r->in_range(values[i]), "the simulator took a write the profile refuses");
        }
    }
}

// An accepted request: what it touched is allowed, and its writes are logged.
void check_served(const sim::ProfileDrive& drive, const rtu::Request& request) {
    const auto& p = drive.profile();
    if (const auto* read = std::get_if<rtu::ReadHoldingRegisters>(&request)) {
        check_access(p, 3, read->start, {}, read->quantity);
    } else if (const auto* one = std::get_if<rtu::WriteSingleRegister>(&request)) {
        const std::uint16_t value[] = {one->value};
        check_access(p, 6, one->address, value, 1);
        check(!drive.write_log().empty() && drive.write_log().back() == std::pair(one->address, one->value),
              "an accepted FC06 is not the last entry of the write log");
    } else if (const auto* many = std::get_if<rtu::WriteMultipleRegisters>(&request)) {
        check_access(p, 16, many->start, many->values.words(), many->values.size());
        const auto words = many->values.words();
        check(drive.write_log().back() ==
                  std::pair(static_cast<std::uint16_t>(many->start + words.size() - 1), words.back()),
              "an accepted FC16 is not at the end of the write log");
    }
}

void check_reply(sim::Bus& bus, const rtu::Frame& frame, const sim::TxPlan& plan) {
    const auto bytes = frame.adu.bytes();
    const auto request = rtu::decode_request(bytes);
    if (plan.empty()) {
        return;
    }
    const rtu::SlaveAddress address = bytes[0];
    check(address != rtu::kBroadcastAddress, "a reply to a broadcast");
    auto* drive = bus.drive(address);
    check(drive != nullptr, "a reply from an address no drive has");

    rtu::Adu reply;
    rtu::Instant previous = frame.last + kTiming.t3_5 + kTurnaround;
    for (const auto& b : plan) {
        check(b.at > previous, "reply bytes not paced after the request's end + t3.5 + turnaround");
        previous = b.at;
        check(reply.push_back(b.value), "a reply longer than an ADU");
    }
    check(plan.back().reply_end && plan.back().address == address, "the reply's end is not marked");
    check(reply[0] == address && rtu::crc_ok(reply.bytes()), "a reply with another address or a bad CRC");

    if (!request) {
        // Only an exception answers a frame the drive cannot decode.
        check(reply.size() == 5 && reply[1] == (bytes[1] | rtu::kExceptionFlag), "a reply to an undecodable frame");
        return;
    }
    check(rtu::reply_bytes_needed(*request, reply.bytes()) == reply.size(), "a reply the master would frame apart");
    const auto decoded = rtu::decode_response(*request, reply.bytes());
    check(decoded.has_value(), "a reply the master cannot decode for its request");
    if (!std::holds_alternative<rtu::ExceptionResponse>(decoded->pdu)) {
        check_served(*drive, request->pdu);
    }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    static const auto atv21 = fuzz::shipped_profile("atv21");
    static const auto atv58 = fuzz::shipped_profile("atv58");
    sim::Bus bus({kTiming, kTurnaround, true, 1});
    bus.add(sim::make_drive(1, atv21));
    bus.add(sim::make_drive(2, atv58));

    rtu::Instant now{std::chrono::seconds(1000)};
    std::size_t pos = 0;
    while (pos + 2 <= size) {
        const std::uint8_t flags = data[pos];
        const std::size_t length = std::min<std::size_t>({data[pos + 1], size - pos - 2, rtu::kMaxAduSize - 2});
        const std::span<const std::uint8_t> body(data + pos + 2, length);
        pos += 2 + length;
        rtu::Frame frame;
        (void)frame.adu.append(body);
        (void)frame.adu.append_crc();
        if (frame.adu.size() < rtu::kMinAduSize) {
            continue;
        }
        now += std::chrono::milliseconds(10 * (flags >> 1U));
        frame.first = now;
        frame.last = now + kTiming.character * static_cast<std::int64_t>(frame.adu.size() - 1);
        now = frame.last;
        const auto plan = bus.on_frame(frame);
        check_reply(bus, frame, plan);
        if (!plan.empty()) {
            now = plan.back().at;
        }
    }
    return 0;
}
