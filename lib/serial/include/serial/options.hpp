// SPDX-License-Identifier: Apache-2.0
// The settings of the direction methods, as the configuration gives them: plain values, no
// port, no system header, so that the configuration can hold them without the port code.
#pragma once

#include <cstdint>
#include <string>

namespace drivebus::serial {

struct KernelRs485Options {
    bool rts_on_send = true;
    bool rts_after_send = false;
    bool rx_during_tx = false;
    std::uint32_t delay_before_send_ms = 0;
    std::uint32_t delay_after_send_ms = 0;
};

struct GpioOptions {
    std::string chip;  // "gpiochip0", "/dev/gpiochip0" or a chip label
    unsigned line = 0;
    bool active_low = false;
};

}  // namespace drivebus::serial
