// SPDX-License-Identifier: Apache-2.0
// Vocabulary types of Modbus RTU: addresses, function and exception codes, the ADU buffer.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>

namespace drivebus::rtu {

// Slave address on the line. 0 is broadcast, 1-247 are unicast, 248-255 are reserved.
using SlaveAddress = std::uint8_t;
inline constexpr SlaveAddress kBroadcastAddress = 0;
inline constexpr SlaveAddress kMaxUnicastAddress = 247;

// Serial line ADU limit (address + PDU + CRC), Modbus over serial line V1.02, 2.5.1.
inline constexpr std::size_t kMaxAduSize = 256;
inline constexpr std::size_t kMinAduSize = 4;  // address, function, CRC

// Spec quantity limits (Modbus application protocol V1.1b3, 6.3 and 6.12).
inline constexpr std::uint16_t kMaxReadRegisters = 125;
inline constexpr std::uint16_t kMaxWriteRegisters = 123;

enum class FunctionCode : std::uint8_t {
    ReadHoldingRegisters = 0x03,
    WriteSingleRegister = 0x06,
    WriteMultipleRegisters = 0x10,
    EncapsulatedInterface = 0x2B,  // with MEI type 0x0E: Read Device Identification
};
inline constexpr std::uint8_t kExceptionFlag = 0x80;
inline constexpr std::uint8_t kMeiReadDeviceIdentification = 0x0E;

// Exception codes of the Modbus application protocol V1.1b3, section 7.
// Other values can arrive on the wire; they are kept as their raw number.
enum class ExceptionCode : std::uint8_t {
    IllegalFunction = 0x01,
    IllegalDataAddress = 0x02,
    IllegalDataValue = 0x03,
    ServerDeviceFailure = 0x04,
    Acknowledge = 0x05,
    ServerDeviceBusy = 0x06,
    MemoryParityError = 0x08,
    GatewayPathUnavailable = 0x0A,
    GatewayTargetFailedToRespond = 0x0B,
};

std::string_view to_string(FunctionCode code) noexcept;
std::string_view to_string(ExceptionCode code) noexcept;
bool is_defined(ExceptionCode code) noexcept;

// A complete serial-line frame: address, PDU and CRC, at most 256 bytes. Fixed storage, no heap.
class Adu {
public:
    Adu() = default;

    [[nodiscard]] std::span<const std::uint8_t> bytes() const noexcept { return {data_.data(), size_}; }
    [[nodiscard]] std::size_t size() const noexcept { return size_; }
    [[nodiscard]] bool empty() const noexcept { return size_ == 0; }
    [[nodiscard]] bool full() const noexcept { return size_ == kMaxAduSize; }
    [[nodiscard]] std::uint8_t operator[](std::size_t i) const noexcept { return data_[i]; }

    // Returns false (and changes nothing) when the frame would exceed 256 bytes.
    bool push_back(std::uint8_t byte) noexcept;
    bool append(std::span<const std::uint8_t> bytes) noexcept;
    bool append_u16(std::uint16_t word) noexcept;  // big-endian, as Modbus data fields are
    // Appends the CRC16 of the current contents, low byte first.
    bool append_crc() noexcept;
    void clear() noexcept { size_ = 0; }

    friend bool operator==(const Adu& a, const Adu& b) noexcept;

private:
    std::array<std::uint8_t, kMaxAduSize> data_{};
    std::size_t size_ = 0;
};

// Register values of one read or write: at most 125 words, fixed storage.
class RegisterValues {
public:
    static constexpr std::size_t kCapacity = kMaxReadRegisters;

    RegisterValues() = default;
    RegisterValues(std::initializer_list<std::uint16_t> words) noexcept;
    // Copies at most kCapacity words; check size() if the source may be longer.
    explicit RegisterValues(std::span<const std::uint16_t> words) noexcept;

    [[nodiscard]] std::span<const std::uint16_t> words() const noexcept { return {data_.data(), size_}; }
    [[nodiscard]] std::size_t size() const noexcept { return size_; }
    [[nodiscard]] std::uint16_t operator[](std::size_t i) const noexcept { return data_[i]; }
    bool push_back(std::uint16_t word) noexcept;

    friend bool operator==(const RegisterValues& a, const RegisterValues& b) noexcept;

private:
    std::array<std::uint16_t, kCapacity> data_{};
    std::size_t size_ = 0;
};

}  // namespace drivebus::rtu
