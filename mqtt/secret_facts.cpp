// SPDX-License-Identifier: Apache-2.0
#include "secret_facts.hpp"

#include <grp.h>
#include <pwd.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <system_error>
#include <utility>

namespace drivebus::mqtt {

namespace {

std::string user_name(uid_t uid) {
    const passwd* pw = ::getpwuid(uid);
    return pw != nullptr ? std::string(pw->pw_name) : std::to_string(uid);
}

}  // namespace

Account this_account() {
    const uid_t uid = ::geteuid();
    return Account{.uid = uid, .name = user_name(uid)};
}

std::expected<SecretFile, std::string> read_secret_file(std::string key, const std::filesystem::path& path) {
    struct stat st{};
    if (::stat(path.c_str(), &st) != 0) {
        return std::unexpected(key + ": " + path.string() + ": " + std::system_category().message(errno));
    }
    SecretFile file;
    file.key = std::move(key);
    file.path = path;
    file.owner = Account{.uid = st.st_uid, .name = user_name(st.st_uid)};
    file.mode = st.st_mode & 07777U;
    const group* g = ::getgrgid(st.st_gid);
    file.group = g != nullptr ? std::string(g->gr_name) : std::to_string(st.st_gid);
    if (g != nullptr) {
        for (char* const* member = g->gr_mem; *member != nullptr; ++member) {
            file.group_members.emplace_back(*member);
        }
    }
    // The users whose primary group it is are members too, without being listed. Start-up only:
    // nothing else walks the account database at the same time.
    ::setpwent();
    while (const passwd* pw = ::getpwent()) {
        if (pw->pw_gid == st.st_gid) {
            file.group_members.emplace_back(pw->pw_name);
        }
    }
    ::endpwent();
    return file;
}

}  // namespace drivebus::mqtt
