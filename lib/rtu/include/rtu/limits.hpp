// SPDX-License-Identifier: Apache-2.0
// What a slave accepts: the spec's limits narrowed by a drive's own (from its profile).
#pragma once

#include <cstdint>
#include <vector>

#include "rtu/types.hpp"

namespace drivebus::rtu {

// A register window where a drive accepts a quantity outside its plain limit, such as the
// Altivar 21's indirect read block (FC03, 2-5 words at 0x1875).
struct BlockWindow {
    FunctionCode function = FunctionCode::ReadHoldingRegisters;
    std::uint16_t start = 0;
    std::uint16_t min_quantity = 1;
    std::uint16_t max_quantity = 1;
};

struct FunctionLimits {
    SlaveAddress max_address = kMaxUnicastAddress;
    std::uint16_t max_read = kMaxReadRegisters;    // FC03 words
    std::uint16_t max_write = kMaxWriteRegisters;  // FC16 words
    bool read_holding = true;
    bool write_single = true;
    bool write_multiple = true;
    bool device_identification = true;
    bool broadcast_write_single = true;    // FC06 to address 0
    bool broadcast_write_multiple = true;  // FC16 to address 0
    std::vector<BlockWindow> windows;

    // The spec's own limits; every Modbus slave at least claims these.
    [[nodiscard]] static FunctionLimits modbus_spec() { return {}; }
};

}  // namespace drivebus::rtu
