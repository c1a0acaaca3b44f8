// SPDX-License-Identifier: Apache-2.0
#include "rtu/device_id.hpp"

namespace drivebus::rtu::detail {
namespace {
constexpr std::uint8_t kMoreFollows = 0xFF;
constexpr std::size_t kFrameHeader = 2 + kDeviceIdHeader;  // address, function, header
constexpr std::size_t kCrcSize = 2;
}  // namespace

std::expected<DeviceIdentificationResponse, DecodeError> decode_device_id(ByteReader& in) {
    const auto mei = in.u8();
    const auto code = in.u8();
    const auto conformity = in.u8();
    const auto more = in.u8();
    const auto next = in.u8();
    const auto count = in.u8();
    if (!mei || !code || !conformity || !more || !next || !count) {
        return std::unexpected(DecodeError::TooShort);
    }
    if (*mei != kMeiReadDeviceIdentification) {
        return std::unexpected(DecodeError::InvalidMeiType);
    }
    if (*code < 1 || *code > 4) {
        return std::unexpected(DecodeError::InvalidDeviceIdCode);
    }
    if (*more != 0x00 && *more != kMoreFollows) {
        return std::unexpected(DecodeError::InvalidField);
    }
    DeviceIdentificationResponse response;
    response.code = static_cast<DeviceIdCode>(*code);
    response.conformity = *conformity;
    response.more_follows = *more == kMoreFollows;
    response.next_object_id = *next;
    response.objects.reserve(*count);
    for (std::uint8_t i = 0; i < *count; ++i) {
        const auto id = in.u8();
        const auto length = in.u8();
        if (!id || !length) {
            return std::unexpected(DecodeError::ObjectOverrun);
        }
        const auto value = in.take(*length);
        if (!value) {
            return std::unexpected(DecodeError::ObjectOverrun);
        }
        response.objects.push_back({*id, std::string(value->begin(), value->end())});
    }
    if (in.remaining() != 0) {
        return std::unexpected(DecodeError::LengthMismatch);
    }
    return response;
}

bool encode_device_id(Adu& adu, const DeviceIdentificationResponse& response) {
    if (response.objects.size() > 0xFF) {
        return false;
    }
    bool ok = adu.push_back(kMeiReadDeviceIdentification) && adu.push_back(static_cast<std::uint8_t>(response.code)) &&
              adu.push_back(response.conformity) && adu.push_back(response.more_follows ? kMoreFollows : 0x00) &&
              adu.push_back(response.next_object_id) &&
              adu.push_back(static_cast<std::uint8_t>(response.objects.size()));
    for (const DeviceObject& object : response.objects) {
        if (object.value.size() > 0xFF) {
            return false;
        }
        const auto* data = reinterpret_cast<const std::uint8_t*>(object.value.data());
        ok = ok && adu.push_back(object.id) && adu.push_back(static_cast<std::uint8_t>(object.value.size())) &&
             adu.append({data, object.value.size()});
    }
    return ok;
}

std::size_t device_id_bytes_needed(std::span<const std::uint8_t> received) noexcept {
    if (received.size() < kFrameHeader) {
        return kFrameHeader;
    }
    const std::uint8_t count = received[kFrameHeader - 1];
    std::size_t position = kFrameHeader;
    for (std::uint8_t i = 0; i < count; ++i) {
        if (position + 2 + kCrcSize > kMaxAduSize) {
            return 0;
        }
        if (received.size() < position + 2) {
            return position + 2;
        }
        position += 2U + received[position + 1];
        if (position + kCrcSize > kMaxAduSize) {
            return 0;
        }
    }
    return position + kCrcSize;
}

}  // namespace drivebus::rtu::detail
