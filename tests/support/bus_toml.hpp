// SPDX-License-Identifier: Apache-2.0
// The bus the ipc core's tests and the admission fuzzer read, as its configuration's text:
// "line1" on /dev/ttyUSB0 without parity, the pump an Altivar 21 at address 1 and, on the
// two-drive bus, the fan an Altivar 58 at address 2. `pump_keys` adds keys to the pump's table,
// each "key = value" (a lease, a fallback, a write block).
#pragma once

#include <initializer_list>
#include <string>
#include <string_view>

namespace drivebus::test {

inline std::string pump_toml(std::initializer_list<std::string_view> pump_keys = {}) {
    std::string text = R"([[bus]]
name = "line1"
device = "/dev/ttyUSB0"
parity = "none"
  [[bus.drive]]
  name = "pump"
  address = 1
  profile = "atv21"
)";
    for (const auto key : pump_keys) {
        text.append("  ").append(key).append("\n");
    }
    return text;
}

inline std::string pump_and_fan_toml(std::initializer_list<std::string_view> pump_keys = {}) {
    return pump_toml(pump_keys) + R"(  [[bus.drive]]
  name = "fan"
  address = 2
  profile = "atv58"
)";
}

}  // namespace drivebus::test
