// SPDX-License-Identifier: Apache-2.0
// Modbus requests and responses as values: what the codec encodes and decodes.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "rtu/types.hpp"

namespace drivebus::rtu {

// ---- requests (master -> slave) ----

struct ReadHoldingRegisters {  // FC 03
    std::uint16_t start = 0;
    std::uint16_t quantity = 0;
    friend bool operator==(const ReadHoldingRegisters&, const ReadHoldingRegisters&) = default;
};

struct WriteSingleRegister {  // FC 06
    std::uint16_t address = 0;
    std::uint16_t value = 0;
    friend bool operator==(const WriteSingleRegister&, const WriteSingleRegister&) = default;
};

struct WriteMultipleRegisters {  // FC 16
    std::uint16_t start = 0;
    RegisterValues values;
    friend bool operator==(const WriteMultipleRegisters&, const WriteMultipleRegisters&) = default;
};

// Read Device Identification access codes (Modbus application protocol V1.1b3, 6.21).
enum class DeviceIdCode : std::uint8_t {
    Basic = 0x01,     // stream access: objects 0-2
    Regular = 0x02,   // stream access: objects 0-0x7F
    Extended = 0x03,  // stream access: objects 0-0xFF
    Specific = 0x04,  // one object
};

struct ReadDeviceIdentification {  // FC 43 / MEI 14
    DeviceIdCode code = DeviceIdCode::Basic;
    std::uint8_t object_id = 0;
    friend bool operator==(const ReadDeviceIdentification&, const ReadDeviceIdentification&) = default;
};

using Request =
    std::variant<ReadHoldingRegisters, WriteSingleRegister, WriteMultipleRegisters, ReadDeviceIdentification>;

struct RequestAdu {
    SlaveAddress address = 0;
    Request pdu;
    friend bool operator==(const RequestAdu&, const RequestAdu&) = default;
};

[[nodiscard]] FunctionCode function_of(const Request& request) noexcept;

// ---- responses (slave -> master) ----

struct ReadHoldingRegistersResponse {
    RegisterValues values;
    friend bool operator==(const ReadHoldingRegistersResponse&, const ReadHoldingRegistersResponse&) = default;
};

struct WriteSingleRegisterResponse {  // echoes the request
    std::uint16_t address = 0;
    std::uint16_t value = 0;
    friend bool operator==(const WriteSingleRegisterResponse&, const WriteSingleRegisterResponse&) = default;
};

struct WriteMultipleRegistersResponse {
    std::uint16_t start = 0;
    std::uint16_t quantity = 0;
    friend bool operator==(const WriteMultipleRegistersResponse&, const WriteMultipleRegistersResponse&) = default;
};

struct DeviceObject {
    std::uint8_t id = 0;
    std::string value;  // as sent: ASCII for the basic objects
    friend bool operator==(const DeviceObject&, const DeviceObject&) = default;
};

struct DeviceIdentificationResponse {
    DeviceIdCode code = DeviceIdCode::Basic;
    std::uint8_t conformity = 0x01;  // 0x01 basic stream only, 0x81 adds individual access
    bool more_follows = false;
    std::uint8_t next_object_id = 0;
    std::vector<DeviceObject> objects;
    friend bool operator==(const DeviceIdentificationResponse&, const DeviceIdentificationResponse&) = default;
};

struct ExceptionResponse {
    std::uint8_t function = 0;  // the request's function code, without the 0x80 flag
    ExceptionCode code = ExceptionCode::IllegalFunction;
    friend bool operator==(const ExceptionResponse&, const ExceptionResponse&) = default;
};

using Response = std::variant<ReadHoldingRegistersResponse, WriteSingleRegisterResponse, WriteMultipleRegistersResponse,
                              DeviceIdentificationResponse, ExceptionResponse>;

struct ResponseAdu {
    SlaveAddress address = 0;
    Response pdu;
    friend bool operator==(const ResponseAdu&, const ResponseAdu&) = default;
};

}  // namespace drivebus::rtu
