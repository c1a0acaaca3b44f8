// SPDX-License-Identifier: Apache-2.0
// Item 0: the machine's own floors under the suite's figures, measured in the same run with no
// drivebus code on the path. A figure of drivebus's that crosses a pty, an iceoryx notification
// or a timer's wake-up cannot be lower than these.
#pragma once

#include <vector>

#include "suite_tools.hpp"

namespace drivebus::bench {

void floors(const Options& o, std::vector<Row>& rows);

}  // namespace drivebus::bench
