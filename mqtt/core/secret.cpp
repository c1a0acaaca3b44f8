// SPDX-License-Identifier: Apache-2.0
#include "mqtt/secret.hpp"

#include <algorithm>

namespace drivebus::mqtt {

namespace {

std::string octal(unsigned mode) {  // "0640"
    std::string text(4, '0');
    for (auto digit = text.rbegin(); digit != text.rend(); ++digit, mode >>= 3U) {
        *digit = static_cast<char>('0' + (mode & 07U));
    }
    return text;
}

std::string joined(const std::vector<std::string>& names) {
    std::string out;
    for (const auto& n : names) {
        out += (out.empty() ? "" : ", ") + n;
    }
    return out;
}

}  // namespace

std::optional<std::string> secret_problem(const SecretFile& file, const Account& bridge) {
    const auto head = file.key + ": " + file.path.string() + " ";
    if (file.owner.uid != 0 && file.owner.uid != bridge.uid) {
        return head + "belongs to " + file.owner.name +
               ": a secret of the bridge belongs to root or to its own user (" + bridge.name + ")";
    }
    if ((file.mode & 07U) != 0) {
        return head + "is open to every user (mode " + octal(file.mode) + "): chmod o= " + file.path.string();
    }
    if ((file.mode & 070U) == 0) {
        return std::nullopt;
    }
    std::vector<std::string> others;
    for (const auto& member : file.group_members) {
        if (member != bridge.name && member != "root" && std::ranges::find(others, member) == others.end()) {
            others.push_back(member);
        }
    }
    std::ranges::sort(others);
    if (others.empty() || (bridge.uid == 0 && others.size() == 1)) {
        return std::nullopt;
    }
    return head + "is open to group " + file.group + " (mode " + octal(file.mode) + "), which has members besides " +
           bridge.name + ": " + joined(others) + "; give it a group of the bridge's alone (chgrp drivebus-mqtt " +
           file.path.string() + ") or chmod g= " + file.path.string();
}

}  // namespace drivebus::mqtt
