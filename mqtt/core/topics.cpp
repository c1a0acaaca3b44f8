// SPDX-License-Identifier: Apache-2.0
#include "mqtt/topics.hpp"

#include "mqtt/config.hpp"

namespace drivebus::mqtt {

std::optional<Topics::Target> Topics::parse_set(std::string_view topic) const {
    if (!topic.starts_with(root_) || topic.size() <= root_.size() || topic[root_.size()] != '/') {
        return std::nullopt;
    }
    topic.remove_prefix(root_.size() + 1);
    const auto first = topic.find('/');
    if (first == std::string_view::npos) {
        return std::nullopt;
    }
    const auto second = topic.find('/', first + 1);
    if (second == std::string_view::npos || topic.substr(second + 1) != "set") {
        return std::nullopt;
    }
    Target t{std::string(topic.substr(0, first)), std::string(topic.substr(first + 1, second - first - 1))};
    if (!valid_level(t.bus) || !valid_level(t.drive)) {
        return std::nullopt;
    }
    return t;
}

}  // namespace drivebus::mqtt
