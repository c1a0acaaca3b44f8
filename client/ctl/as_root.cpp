// SPDX-License-Identifier: Apache-2.0
#include "as_root.hpp"

#include <grp.h>
#include <pwd.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <optional>

namespace drivebus::ctl {
namespace {

constexpr char kRouDiSocket[] = "/tmp/roudi";

std::optional<passwd> user_named(const std::string& name, std::string& storage) {
    passwd pw{};
    passwd* found = nullptr;
    storage.assign(16384, '\0');
    if (::getpwnam_r(name.c_str(), &pw, storage.data(), storage.size(), &found) != 0 || found == nullptr) {
        return std::nullopt;
    }
    return pw;
}

std::optional<passwd> user_with(uid_t uid, std::string& storage) {
    passwd pw{};
    passwd* found = nullptr;
    storage.assign(16384, '\0');
    if (::getpwuid_r(uid, &pw, storage.data(), storage.size(), &found) != 0 || found == nullptr) {
        return std::nullopt;
    }
    return pw;
}

}  // namespace

std::expected<Identity, std::string> identity_for_root(uid_t roudi_owner, gid_t roudi_group,
                                                       const std::string& sudo_user) {
    std::string storage;
    if (!sudo_user.empty() && sudo_user != "root") {
        if (const auto pw = user_named(sudo_user, storage); pw && pw->pw_uid != 0) {
            return Identity{pw->pw_name, pw->pw_uid, roudi_group};
        }
        return std::unexpected("SUDO_USER " + sudo_user + " is not a user of this machine");
    }
    if (const auto pw = user_with(roudi_owner, storage); pw && pw->pw_uid != 0) {
        return Identity{pw->pw_name, pw->pw_uid, roudi_group};
    }
    return std::unexpected("the RouDi's socket (/tmp/roudi) belongs to uid " + std::to_string(roudi_owner) +
                           ", which is no user of this machine");
}

std::expected<std::string, std::string> leave_root() {
    static std::once_flag once;
    static std::expected<std::string, std::string> result{std::string()};
    std::call_once(once, [] {
        struct stat roudi{};
        if (::geteuid() != 0 || ::stat(kRouDiSocket, &roudi) != 0 || roudi.st_uid == 0) {
            return;  // not root, no RouDi (drivebusctl says so), or a RouDi root runs
        }
        const char* sudo = std::getenv("SUDO_USER");
        auto who = identity_for_root(roudi.st_uid, roudi.st_gid, sudo != nullptr ? sudo : "");
        if (!who) {
            result = std::unexpected(who.error());
            return;
        }
        // Its own groups, so that iceoryx grants it what it grants that user; then the RouDi's
        // group as the effective one; then the user, which gives up root for good.
        if (::initgroups(who->user.c_str(), who->group) != 0 || ::setresgid(who->group, who->group, who->group) != 0 ||
            ::setresuid(who->uid, who->uid, who->uid) != 0) {
            result = std::unexpected("cannot become " + who->user + ": " + std::strerror(errno));
            return;
        }
        result = who->user;
    });
    return result;
}

}  // namespace drivebus::ctl
