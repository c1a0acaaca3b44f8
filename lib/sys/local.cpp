// SPDX-License-Identifier: Apache-2.0
#include "sys/local.hpp"

#include <grp.h>
#include <pwd.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>

namespace drivebus::sys {

std::expected<void, SysError> datagram_socket_answers(const std::string& path) {
    sockaddr_un addr{};
    if (path.size() >= sizeof(addr.sun_path)) {
        return std::unexpected(SysError{"connect", ENAMETOOLONG});
    }
    const auto fd = posix_call("socket", [] { return ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0); });
    if (!fd) {
        return std::unexpected(fd.error());
    }
    const UniqueFd owned(*fd);
    addr.sun_family = AF_UNIX;
    std::memcpy(addr.sun_path, path.c_str(), path.size() + 1);
    const auto connected = posix_call(
        "connect", [&] { return ::connect(owned.get(), reinterpret_cast<const sockaddr*>(&addr), sizeof addr); });
    if (!connected) {
        return std::unexpected(connected.error());
    }
    return {};
}

std::vector<std::string> groups_of_this_user() {
    std::vector<std::string> names;
    const passwd* pw = ::getpwuid(::geteuid());
    if (pw == nullptr) {
        return names;
    }
    int n = 64;
    std::vector<gid_t> gids(static_cast<std::size_t>(n));
    if (::getgrouplist(pw->pw_name, pw->pw_gid, gids.data(), &n) < 0) {
        gids.resize(static_cast<std::size_t>(n));  // n is now the number it has
        ::getgrouplist(pw->pw_name, pw->pw_gid, gids.data(), &n);
    }
    gids.resize(static_cast<std::size_t>(std::max(n, 0)));
    for (const gid_t gid : gids) {
        if (const group* g = ::getgrgid(gid)) {
            names.emplace_back(g->gr_name);
        }
    }
    return names;
}

bool user_in_group(const std::string& name) {
    const group* g = ::getgrnam(name.c_str());
    if (g == nullptr) {
        return false;
    }
    if (::getegid() == g->gr_gid) {
        return true;
    }
    const auto mine = groups_of_this_user();
    return std::ranges::find(mine, name) != mine.end();
}

}  // namespace drivebus::sys
