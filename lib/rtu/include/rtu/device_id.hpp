// SPDX-License-Identifier: Apache-2.0
// Read Device Identification (FC 43 / MEI 14) response body, shared by the response codec.
#pragma once

#include <cstddef>
#include <cstdint>
#include <expected>
#include <span>

#include "rtu/byte_reader.hpp"
#include "rtu/errors.hpp"
#include "rtu/pdu.hpp"

namespace drivebus::rtu::detail {

// Header after address and function: MEI, read code, conformity, more follows, next id, count.
inline constexpr std::size_t kDeviceIdHeader = 6;

// Reads the body that follows the function code, up to (not including) the CRC.
std::expected<DeviceIdentificationResponse, DecodeError> decode_device_id(ByteReader& in);

bool encode_device_id(Adu& adu, const DeviceIdentificationResponse& response);

// Total frame length a device identification reply needs, judging from its first bytes;
// 0 when its object lengths run past 256 bytes.
std::size_t device_id_bytes_needed(std::span<const std::uint8_t> received) noexcept;

}  // namespace drivebus::rtu::detail
