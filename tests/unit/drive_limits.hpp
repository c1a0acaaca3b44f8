// SPDX-License-Identifier: Apache-2.0
// Function limits of the two seed drives, as their manuals state them.
#pragma once

#include "rtu/limits.hpp"

namespace drivebus::test {

// Altivar 21 Modbus guide, 7.3: FC03 one word or an indirect block of 2-5 words at 0x1875,
// FC16 one word or an indirect block of 2 words at 0x1870, FC43/14, addresses 1-247.
inline rtu::FunctionLimits atv21_limits() {
    rtu::FunctionLimits limits;
    limits.max_read = 1;
    limits.max_write = 1;
    limits.windows = {
        {rtu::FunctionCode::ReadHoldingRegisters, 0x1875, 2, 5},
        {rtu::FunctionCode::WriteMultipleRegisters, 0x1870, 2, 2},
    };
    return limits;
}

// Altivar 58 RS485 kit manual: addresses 1-31, FC03 <= 32 words, FC16 <= 30 words, no FC43.
inline rtu::FunctionLimits atv58_limits() {
    rtu::FunctionLimits limits;
    limits.max_address = 31;
    limits.max_read = 32;
    limits.max_write = 30;
    limits.device_identification = false;
    return limits;
}

}  // namespace drivebus::test
