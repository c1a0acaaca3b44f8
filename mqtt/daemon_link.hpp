// SPDX-License-Identifier: Apache-2.0
// drivebusd as the Relay sees it (mqtt/ports.hpp), on libdrivebus with Delivery::Dispatch: no
// thread of the library's; statuses, snapshots and answers arrive in dispatch(), on the
// bridge's loop.
#pragma once

#include "mqtt/ports.hpp"

namespace drivebus::mqtt {

class DaemonLink final : public Daemon {
public:
    std::expected<std::unique_ptr<BusPort>, std::string> connect(std::string_view name) override;
};

}  // namespace drivebus::mqtt
