// SPDX-License-Identifier: Apache-2.0
// Linked into the test programs that start a RouDi (drivebusd's embedded one, or iox-roudi):
// before main(), the process takes its own mount and network namespaces, with an empty /tmp
// and /dev/shm of its own (where iceoryx keeps its sockets, lock file and shared memory) and
// its own loopback. Everything the test starts inherits them, so two such tests, run at once
// by ctest, each see one RouDi and their own TCP ports, as if alone on the machine. A checkout
// under /tmp stays visible (its entry of /tmp is bound into the new one).
//
// Needs root (CAP_SYS_ADMIN), as the build that links this found when it was configured
// (tests/CMakeLists.txt, DRIVEBUS_TEST_PRIVATE_IPC). Without it the process says so and
// stops: the tests would otherwise meet each other's RouDi.
#include <fcntl.h>
#include <net/if.h>
#include <sched.h>
#include <sys/ioctl.h>
#include <sys/mount.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <string>
#include <string_view>
#include <vector>

namespace {

[[noreturn]] void give_up(const char* what) {
    std::fprintf(stderr,
                 "tests: a private /tmp, /dev/shm and network for this test (DRIVEBUS_TEST_PRIVATE_IPC): %s: %s\n"
                 "tests: run the tests as root, or configure with -DDRIVEBUS_TEST_PRIVATE_IPC=OFF (one RouDi "
                 "test at a time)\n",
                 what, std::strerror(errno));
    ::_exit(1);
}

void loopback_up() {
    const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    if (fd < 0) {
        give_up("socket");
    }
    ifreq request{};
    std::strncpy(request.ifr_name, "lo", IFNAMSIZ - 1);
    if (::ioctl(fd, SIOCGIFFLAGS, &request) != 0) {
        give_up("SIOCGIFFLAGS lo");
    }
    request.ifr_flags = static_cast<short>(request.ifr_flags | IFF_UP);
    if (::ioctl(fd, SIOCSIFFLAGS, &request) != 0) {
        give_up("SIOCSIFFLAGS lo up");
    }
    ::close(fd);
}

// The entry of /tmp that `path` is under ("ci-1234" for /tmp/ci-1234/build/tests), if any.
std::string top_in_tmp(const std::string& path) {
    constexpr std::string_view kTmp = "/tmp/";
    if (path.size() <= kTmp.size() || path.compare(0, kTmp.size(), kTmp) != 0) {
        return {};
    }
    return path.substr(kTmp.size(), path.find('/', kTmp.size()) - kTmp.size());
}

// The source and build trees, the program and the working directory stay where they are when
// they are under /tmp (a checkout there): their entries of the machine's /tmp are bound into
// the new one.
std::vector<std::string> tops_to_keep() {
    std::vector<std::string> paths{DRIVEBUS_SOURCE_DIR, DRIVEBUS_BINARY_DIR};
    std::array<char, 4096> buffer{};
    if (const auto n = ::readlink("/proc/self/exe", buffer.data(), buffer.size() - 1); n > 0) {
        paths.emplace_back(buffer.data(), static_cast<std::size_t>(n));
    }
    if (::getcwd(buffer.data(), buffer.size()) != nullptr) {
        paths.emplace_back(buffer.data());
    }
    std::vector<std::string> tops;
    for (const auto& path : paths) {
        if (auto top = top_in_tmp(path); !top.empty() && std::ranges::find(tops, top) == tops.end()) {
            tops.push_back(std::move(top));
        }
    }
    return tops;
}

__attribute__((constructor)) void private_ipc() {
    const auto keep = tops_to_keep();
    if (::unshare(CLONE_NEWNS | CLONE_NEWNET) != 0) {
        give_up("unshare");
    }
    // Nothing mounted here reaches the machine's namespace.
    if (::mount(nullptr, "/", nullptr, MS_REC | MS_PRIVATE, nullptr) != 0) {
        give_up("making / private");
    }
    const int old_tmp = ::open("/tmp", O_PATH | O_DIRECTORY | O_CLOEXEC);
    if (old_tmp < 0) {
        give_up("/tmp");
    }
    if (::mount("tmpfs", "/tmp", "tmpfs", MS_NOSUID | MS_NODEV, "mode=1777") != 0) {
        give_up("tmpfs on /tmp");
    }
    for (const auto& top : keep) {
        const std::string from = "/proc/self/fd/" + std::to_string(old_tmp) + "/" + top;
        const std::string to = "/tmp/" + top;
        if (::mkdir(to.c_str(), 0755) != 0 ||
            ::mount(from.c_str(), to.c_str(), nullptr, MS_BIND | MS_REC, nullptr) != 0) {
            give_up(("binding " + to + " back").c_str());
        }
    }
    ::close(old_tmp);
    if (::mount("tmpfs", "/dev/shm", "tmpfs", MS_NOSUID | MS_NODEV, "mode=1777") != 0) {
        give_up("tmpfs on /dev/shm");
    }
    loopback_up();
}

}  // namespace
