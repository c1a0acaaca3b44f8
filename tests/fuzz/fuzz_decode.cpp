// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: both decoders and the reply-length logic on arbitrary bytes.
// The first input byte picks the request the reply is decoded against.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>

#include "rtu/codec.hpp"

using namespace drivebus::rtu;

namespace {

RequestAdu request_for(std::uint8_t selector, std::span<const std::uint8_t> frame) {
    const SlaveAddress address = frame.empty() ? 1 : frame[0];
    const auto quantity = static_cast<std::uint16_t>(1U + (selector >> 2U) % 125U);
    switch (selector & 3U) {
    case 0: return {address, ReadHoldingRegisters{0, quantity}};
    case 1: return {address, WriteSingleRegister{0, quantity}};
    case 2: {
        RegisterValues values;
        for (std::uint16_t i = 0; i < quantity && i < kMaxWriteRegisters; ++i) {
            values.push_back(i);
        }
        return {address, WriteMultipleRegisters{0, values}};
    }
    default: return {address, ReadDeviceIdentification{static_cast<DeviceIdCode>(1U + selector % 4U), 0}};
    }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size == 0) {
        return 0;
    }
    const std::span<const std::uint8_t> frame(data + 1, size - 1);

    if (const auto request = decode_request(frame)) {
        if (validate_request(*request).has_value()) {
            const auto again = encode_request(*request);
            if (!again || !std::ranges::equal(again->bytes(), frame)) {
                std::abort();  // a decoded request must re-encode to the same bytes
            }
        }
    }

    const RequestAdu request = request_for(data[0], frame);
    const std::size_t needed = reply_bytes_needed(request, frame);
    if (needed > kMaxAduSize) {
        std::abort();
    }
    if (const auto reply = decode_response(request, frame)) {
        if (needed != frame.size()) {
            std::abort();  // the master would not have framed this reply at this length
        }
        const auto again = encode_response(*reply);
        if (again && !std::ranges::equal(again->bytes(), frame)) {
            std::abort();
        }
    }
    return 0;
}
