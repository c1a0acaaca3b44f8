// SPDX-License-Identifier: Apache-2.0
#include "rtu/types.hpp"

#include <algorithm>

#include "rtu/crc.hpp"

namespace drivebus::rtu {

std::string_view to_string(FunctionCode code) noexcept {
    switch (code) {
    case FunctionCode::ReadHoldingRegisters: return "read holding registers (03)";
    case FunctionCode::WriteSingleRegister: return "write single register (06)";
    case FunctionCode::WriteMultipleRegisters: return "write multiple registers (16)";
    case FunctionCode::EncapsulatedInterface: return "encapsulated interface (43)";
    }
    return "unknown function";
}

bool is_defined(ExceptionCode code) noexcept {
    switch (code) {
    case ExceptionCode::IllegalFunction:
    case ExceptionCode::IllegalDataAddress:
    case ExceptionCode::IllegalDataValue:
    case ExceptionCode::ServerDeviceFailure:
    case ExceptionCode::Acknowledge:
    case ExceptionCode::ServerDeviceBusy:
    case ExceptionCode::MemoryParityError:
    case ExceptionCode::GatewayPathUnavailable:
    case ExceptionCode::GatewayTargetFailedToRespond: return true;
    }
    return false;
}

std::string_view to_string(ExceptionCode code) noexcept {
    switch (code) {
    case ExceptionCode::IllegalFunction: return "illegal function";
    case ExceptionCode::IllegalDataAddress: return "illegal data address";
    case ExceptionCode::IllegalDataValue: return "illegal data value";
    case ExceptionCode::ServerDeviceFailure: return "server device failure";
    case ExceptionCode::Acknowledge: return "acknowledge";
    case ExceptionCode::ServerDeviceBusy: return "server device busy";
    case ExceptionCode::MemoryParityError: return "memory parity error";
    case ExceptionCode::GatewayPathUnavailable: return "gateway path unavailable";
    case ExceptionCode::GatewayTargetFailedToRespond: return "gateway target device failed to respond";
    }
    return "undefined exception code";
}

bool Adu::push_back(std::uint8_t byte) noexcept {
    if (size_ == kMaxAduSize) {
        return false;
    }
    data_[size_++] = byte;
    return true;
}

bool Adu::append(std::span<const std::uint8_t> bytes) noexcept {
    if (bytes.size() > kMaxAduSize - size_) {
        return false;
    }
    std::ranges::copy(bytes, data_.begin() + static_cast<std::ptrdiff_t>(size_));
    size_ += bytes.size();
    return true;
}

bool Adu::append_u16(std::uint16_t word) noexcept {
    const std::array<std::uint8_t, 2> bytes{static_cast<std::uint8_t>(word >> 8U),
                                            static_cast<std::uint8_t>(word & 0xFFU)};
    return append(bytes);
}

bool Adu::append_crc() noexcept {
    const std::uint16_t crc = crc16(bytes());
    const std::array<std::uint8_t, 2> bytes{static_cast<std::uint8_t>(crc & 0xFFU),
                                            static_cast<std::uint8_t>(crc >> 8U)};
    return append(bytes);
}

bool operator==(const Adu& a, const Adu& b) noexcept {
    return std::ranges::equal(a.bytes(), b.bytes());
}

RegisterValues::RegisterValues(std::initializer_list<std::uint16_t> words) noexcept
    : RegisterValues(std::span<const std::uint16_t>(words.begin(), words.size())) {}

RegisterValues::RegisterValues(std::span<const std::uint16_t> words) noexcept
    : size_(std::min(words.size(), kCapacity)) {
    std::ranges::copy(words.first(size_), data_.begin());
}

bool RegisterValues::push_back(std::uint16_t word) noexcept {
    if (size_ == kCapacity) {
        return false;
    }
    data_[size_++] = word;
    return true;
}

bool operator==(const RegisterValues& a, const RegisterValues& b) noexcept {
    return std::ranges::equal(a.words(), b.words());
}

}  // namespace drivebus::rtu
