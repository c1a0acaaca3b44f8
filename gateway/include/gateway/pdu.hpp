// SPDX-License-Identifier: Apache-2.0
// The Modbus requests the gateway serves, parsed from a PDU, and the PDUs it answers with.
// Pure. Function codes: 03 and 04 (read registers), 06 and 16 (write registers), 08
// (diagnostics), 43/14 (read device identification); anything else is exception 01.
#pragma once

#include <cstdint>
#include <expected>
#include <span>
#include <string>
#include <utility>
#include <variant>
#include <vector>

namespace drivebus::gateway {

// Modbus exception codes (Modbus Application Protocol v1.1b3, section 7), as the gateway uses them.
enum class Exception : std::uint8_t {
    IllegalFunction = 0x01,         // not served, or not allowed for this peer (a write, read-only)
    IllegalDataAddress = 0x02,      // a register the drive does not have, or may not be written
    IllegalDataValue = 0x03,        // a quantity or value out of range, a malformed request
    ServerDeviceFailure = 0x04,     // the gateway failed on its side
    ServerDeviceBusy = 0x06,        // another client holds the drive's control lease, or the queue is full
    GatewayPathUnavailable = 0x0A,  // no such unit, drivebusd or the bus is down
    GatewayTargetFailed = 0x0B,     // the drive is absent or did not answer
};

[[nodiscard]] const char* to_string(Exception code) noexcept;

inline constexpr std::uint8_t kReadHolding = 0x03;
inline constexpr std::uint8_t kReadInput = 0x04;
inline constexpr std::uint8_t kWriteSingle = 0x06;
inline constexpr std::uint8_t kDiagnostics = 0x08;
inline constexpr std::uint8_t kWriteMultiple = 0x10;
inline constexpr std::uint8_t kEncapsulated = 0x2B;
inline constexpr std::uint8_t kMeiDeviceId = 0x0E;

struct ReadRegisters {
    std::uint8_t function = kReadHolding;  // 03 or 04: the Altivars have one register space
    std::uint16_t start = 0;
    std::uint16_t count = 0;
};

struct WriteRegisters {
    std::uint8_t function = kWriteSingle;  // 06 or 16
    std::uint16_t start = 0;
    std::vector<std::uint16_t> values;
};

struct ReadDeviceId {
    std::uint8_t code = 1;    // 1: stream the basic objects; 4: one object
    std::uint8_t object = 0;  // the first (1) or the only (4) object asked for
};

struct Diagnostic {
    std::uint16_t sub = 0;
    std::vector<std::uint8_t> data;
};

using Call = std::variant<ReadRegisters, WriteRegisters, ReadDeviceId, Diagnostic>;

struct Refusal {
    std::uint8_t function = 0;
    Exception exception = Exception::IllegalFunction;
};

// The request in `pdu`, or the exception it gets without going further.
[[nodiscard]] std::expected<Call, Refusal> parse_request(std::span<const std::uint8_t> pdu);
[[nodiscard]] std::uint8_t function_of(const Call& call) noexcept;

[[nodiscard]] std::vector<std::uint8_t> exception_pdu(std::uint8_t function, Exception code);
[[nodiscard]] std::vector<std::uint8_t> read_pdu(std::uint8_t function, std::span<const std::uint16_t> values);
// The answer to a write: FC06 echoes register and value, FC16 register and quantity.
[[nodiscard]] std::vector<std::uint8_t> write_pdu(const WriteRegisters& write);
// FC43/14 with the objects asked for (id, text): conformity 0x81 (basic, stream and single).
[[nodiscard]] std::vector<std::uint8_t> device_id_pdu(const ReadDeviceId& request,
                                                      const std::vector<std::pair<std::uint8_t, std::string>>& objects);
[[nodiscard]] std::vector<std::uint8_t> diagnostic_pdu(std::uint16_t sub, std::span<const std::uint8_t> data);

}  // namespace drivebus::gateway
