// SPDX-License-Identifier: Apache-2.0
#include "ipc/leftovers.hpp"

#include <fcntl.h>
#include <pwd.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <fmt/format.h>
#include <algorithm>
#include <cerrno>
#include <charconv>
#include <filesystem>

#include "iceoryx_hoofs/platform/platform_settings.hpp"
#include "iceoryx_posh/iceoryx_posh_types.hpp"
#include "sys/posix.hpp"

namespace drivebus::ipc {
namespace {

namespace fs = std::filesystem;

constexpr std::size_t kMaxClientName = 60;  // libdrivebus cuts the application's name there

std::string owner_name(uid_t uid) {
    const auto* pw = ::getpwuid(uid);
    return pw != nullptr ? std::string(pw->pw_name) : std::to_string(uid);
}

// The pid of a runtime named <name>-<pid> as drivebus names them; nullopt for any other name.
std::optional<pid_t> runtime_pid(std::string_view file) {
    const auto dash = file.rfind('-');
    if (dash == std::string_view::npos || dash == 0 || dash > kMaxClientName || dash + 1 == file.size()) {
        return std::nullopt;
    }
    const auto name = file.substr(0, dash);
    if (!std::ranges::all_of(name, [](char c) {
            return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-';
        })) {
        return std::nullopt;
    }
    const auto digits = file.substr(dash + 1);
    pid_t pid = 0;
    const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), pid);
    if (ec != std::errc{} || end != digits.data() + digits.size() || pid <= 0) {
        return std::nullopt;
    }
    return pid;
}

bool process_gone(pid_t pid) {
    return ::kill(pid, 0) != 0 && errno == ESRCH;
}

// Whether nobody holds the runtime's lock; true only after taking it, with `lock` open.
bool lock_is_free(const std::string& path, sys::UniqueFd& lock) {
    const auto fd = sys::posix_call("open", [&] { return ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW); });
    if (!fd) {
        return false;
    }
    lock.reset(*fd);
    return sys::posix_call("flock", [&] { return ::flock(lock.get(), LOCK_EX | LOCK_NB); }).has_value();
}

// Whether a live process holds the lock at `path` (iceoryx locks with flock).
bool held_by_another(const std::string& path) {
    const auto fd = sys::posix_call("open", [&] { return ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW); });
    if (!fd) {
        return false;
    }
    const sys::UniqueFd lock(*fd);
    const auto taken = sys::posix_call("flock", [&] { return ::flock(lock.get(), LOCK_EX | LOCK_NB); });
    return !taken && taken.error().error == EWOULDBLOCK;
}

}  // namespace

std::optional<std::string> roudi_in_the_way(const std::vector<std::string>& segments) {
    const std::string tmp = iox::platform::IOX_UDS_SOCKET_PATH_PREFIX;
    std::vector<std::string> paths = {
        std::string(iox::platform::IOX_LOCK_FILE_PATH_PREFIX) + iox::roudi::ROUDI_LOCK_NAME + ".lock",
        tmp + iox::roudi::IPC_CHANNEL_ROUDI_NAME,
        tmp + iox::roudi::IPC_CHANNEL_ROUDI_NAME + ".lock",
        std::string("/dev/shm/") + iox::roudi::SHM_NAME,
    };
    for (const auto& segment : segments) {
        paths.push_back("/dev/shm/" + segment);
    }
    if (held_by_another(paths.front())) {
        return fmt::format(
            "a RouDi holds {} but does not answer on {}{} (it is starting, or hangs): wait for it, "
            "or stop that iox-roudi or drivebusd",
            paths.front(), tmp, iox::roudi::IPC_CHANNEL_ROUDI_NAME);
    }
    const auto me = ::geteuid();
    std::string found;
    std::string owners;
    for (const auto& path : paths) {
        struct stat st{};
        // In sticky /tmp and /dev/shm only the owner (or root) may remove or replace a file.
        if (::lstat(path.c_str(), &st) != 0 || st.st_uid == me || me == 0) {
            continue;
        }
        found += (found.empty() ? "" : " ") + path;
        const auto owner = owner_name(st.st_uid);
        if (owners.find(owner) == std::string::npos) {
            owners += (owners.empty() ? "" : ", ") + owner;
        }
    }
    if (found.empty()) {
        return std::nullopt;
    }
    return fmt::format(
        "no RouDi answers on {}{}, but a RouDi of user {} left files this user may not replace "
        "(it did not stop cleanly); if no iox-roudi runs, remove them (sudo rm {}) and start again",
        tmp, iox::roudi::IPC_CHANNEL_ROUDI_NAME, owners, found);
}

std::vector<std::string> remove_stale_client_sockets(const std::string& dir) {
    std::vector<std::string> removed;
    std::error_code ec;
    const auto me = ::geteuid();
    std::vector<fs::path> candidates;  // first listed, then removed: the listing stays whole
    for (const auto& entry : fs::directory_iterator(dir, ec)) {
        const auto pid = runtime_pid(entry.path().filename().string());
        struct stat st{};
        if (pid && ::lstat(entry.path().c_str(), &st) == 0 && S_ISSOCK(st.st_mode) && (st.st_uid == me || me == 0) &&
            process_gone(*pid)) {
            candidates.push_back(entry.path());
        }
    }
    for (const auto& socket : candidates) {
        const auto lock_path = socket.string() + ".lock";
        sys::UniqueFd lock;
        if (!lock_is_free(lock_path, lock)) {
            continue;
        }
        if (::unlink(socket.c_str()) == 0) {
            removed.push_back(socket.string());
        }
        ::unlink(lock_path.c_str());  // still locked by us: no runtime of that name took it meanwhile
    }
    return removed;
}

}  // namespace drivebus::ipc
