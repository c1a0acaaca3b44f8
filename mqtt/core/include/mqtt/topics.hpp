// SPDX-License-Identifier: Apache-2.0
// The bridge's topics, all under drivebus/<node>/ (docs/mqtt.md):
//   drivebus/<node>/status                   "online" / "offline" (birth and last will), retained
//   drivebus/<node>/<bus>/status             the bus status, JSON, retained
//   drivebus/<node>/<bus>/<drive>/state      the drive's decoded state, JSON, retained
//   drivebus/<node>/<bus>/<drive>/set        commands in, QoS 1
//   drivebus/<node>/<bus>/<drive>/result     their results, QoS 1, not retained
#pragma once

#include <optional>
#include <string>
#include <string_view>

namespace drivebus::mqtt {

class Topics {
public:
    explicit Topics(std::string node) : root_("drivebus/" + std::move(node)) {}

    [[nodiscard]] std::string node_status() const { return root_ + "/status"; }
    [[nodiscard]] std::string bus_status(std::string_view bus) const {
        return root_ + "/" + std::string(bus) + "/status";
    }
    [[nodiscard]] std::string state(std::string_view bus, std::string_view drive) const {
        return drive_root(bus, drive) + "/state";
    }
    [[nodiscard]] std::string result(std::string_view bus, std::string_view drive) const {
        return drive_root(bus, drive) + "/result";
    }
    [[nodiscard]] std::string set(std::string_view bus, std::string_view drive) const {
        return drive_root(bus, drive) + "/set";
    }
    // What the bridge subscribes to: every drive's set topic.
    [[nodiscard]] std::string set_filter() const { return root_ + "/+/+/set"; }

    struct Target {
        std::string bus;
        std::string drive;
    };
    // The bus and drive a set topic names; nullopt for anything else (or levels that are not
    // valid names: the result topic is built from them).
    [[nodiscard]] std::optional<Target> parse_set(std::string_view topic) const;

private:
    [[nodiscard]] std::string drive_root(std::string_view bus, std::string_view drive) const {
        return root_ + "/" + std::string(bus) + "/" + std::string(drive);
    }
    std::string root_;
};

}  // namespace drivebus::mqtt
