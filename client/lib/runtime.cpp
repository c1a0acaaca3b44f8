// SPDX-License-Identifier: Apache-2.0
// libdrivebus and the iceoryx runtime: drivebusd's RouDi reached or why not, in words a user can
// act on (not running, which group to join, which effective group), the runtime started once
// per process, and the buses drivebusd announces.
#include <grp.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <thread>

#include "bus_impl.hpp"
#include "iceoryx_hoofs/log/logmanager.hpp"
#include "iceoryx_posh/runtime/posh_runtime.hpp"
#include "iceoryx_posh/runtime/service_discovery.hpp"
#include "log/stream_lines.hpp"
#include "sys/local.hpp"

namespace drivebus {
namespace {

constexpr char kRouDiSocket[] = "/tmp/roudi";
constexpr char kManagementShm[] = "/dev/shm/iceoryx_mgmt";

std::string group_of(const char* path) {
    struct stat st{};
    if (::stat(path, &st) == 0) {
        if (const auto* g = ::getgrgid(st.st_gid)) {
            return g->gr_name;
        }
    }
    return "drivebus";
}

// iceoryx prints on std::clog and std::cerr, with colour escapes: its runtime's complaints when
// drivebusd has gone (a failed keep-alive every few hundred milliseconds, a failed goodbye at
// exit), which the library reports itself in its errors. Those lines are kept off the
// application's terminal; everything else written on the two streams passes through as it was
// written. DRIVEBUS_ICEORYX_LOG=1 leaves the streams alone.
void keep_iceoryx_lines_off_the_terminal() {
    // NOLINTNEXTLINE(concurrency-mt-unsafe): read once, under the runtime's call_once
    if (const char* keep = std::getenv("DRIVEBUS_ICEORYX_LOG"); keep != nullptr && std::string_view(keep) == "1") {
        return;
    }
    const auto filter = [](std::ostream& stream) {
        // Never destroyed: iceoryx's runtime writes from its static destructor at exit.
        // NOLINTNEXTLINE(cppcoreguidelines-owning-memory)
        stream.rdbuf(new log::LineRouter(log::is_iceoryx_line, stream.rdbuf(), log::may_become_iceoryx_line));
    };
    filter(std::clog);
    filter(std::cerr);
}

}  // namespace

namespace {

std::string runtime_name(const std::string& application) {
    std::string name;
    for (const char c : application) {
        name += (std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '-' || c == '_') ? c : '_';
    }
    name = name.substr(0, 60) + "-" + std::to_string(::getpid());
    return name;
}

}  // namespace

std::vector<std::string> discover_buses(std::chrono::milliseconds wait) {
    iox::runtime::ServiceDiscovery discovery;
    std::vector<std::string> buses;
    const auto deadline = Clock::now() + wait;
    do {
        buses.clear();
        discovery.findService(
            iox::cxx::optional<iox::capro::IdString_t>(id(shm::kService)), iox::cxx::nullopt,
            iox::cxx::optional<iox::capro::IdString_t>(id(shm::kStatusEvent)),
            [&](const iox::capro::ServiceDescription& s) { buses.emplace_back(s.getInstanceIDString().c_str()); },
            iox::popo::MessagingPattern::PUB_SUB);
        if (!buses.empty()) {
            break;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
    } while (Clock::now() < deadline);
    std::ranges::sort(buses);
    buses.erase(std::unique(buses.begin(), buses.end()), buses.end());
    return buses;
}

std::expected<void, Error> ensure_runtime(const std::string& application) {
    static std::once_flag once;
    static bool started = false;
    if (const auto answers = sys::datagram_socket_answers(kRouDiSocket); !answers) {
        const int error = answers.error().error;
        if (error == EACCES) {
            const auto group = group_of(kRouDiSocket);
            struct stat st{};
            ::stat(kRouDiSocket, &st);
            char mode[8];
            std::snprintf(mode, sizeof mode, "%04o", st.st_mode & 07777U);
            return std::unexpected(make_error(ErrorKind::NotPermitted,
                                              "this user may not reach drivebusd's RouDi "
                                              "(/tmp/roudi, group " +
                                                  group + ", mode " + mode + "): join group " + group +
                                                  " and log in again"));
        }
        return std::unexpected(make_error(ErrorKind::NotRunning, std::string("drivebusd is not running (/tmp/roudi: ") +
                                                                     std::strerror(error) +
                                                                     "); start it: systemctl start drivebusd"));
    }
    if (::access(kManagementShm, R_OK | W_OK) != 0) {
        const auto group = group_of(kManagementShm);
        return std::unexpected(
            make_error(ErrorKind::NotPermitted, "this user may not use drivebus's shared memory: join group " + group +
                                                    " (usermod -aG " + group + " $USER) and log in again"));
    }
    // RouDi answers each process through a socket the process creates with its effective
    // group and mode 0660: unless RouDi runs as root or as this user, that group must be RouDi's.
    struct stat roudi{};
    if (::stat(kRouDiSocket, &roudi) == 0 && roudi.st_uid != 0 && roudi.st_uid != ::geteuid() &&
        roudi.st_gid != ::getegid()) {
        const auto group = group_of(kRouDiSocket);
        return std::unexpected(make_error(ErrorKind::NotPermitted, "this process's effective group must be " + group +
                                                                       " for drivebusd to answer it: run it with sg " +
                                                                       group + " -c '...', or Group=" + group +
                                                                       " in its unit"));
    }
    std::call_once(once, [&] {
        keep_iceoryx_lines_off_the_terminal();
        iox::log::LogManager::GetLogManager().SetDefaultLogLevel(iox::log::LogLevel::kError,
                                                                 iox::log::LogLevelOutput::kHideLogLevel);
        const auto name = runtime_name(application);
        iox::runtime::PoshRuntime::initRuntime(iox::RuntimeName_t(iox::cxx::TruncateToCapacity, name.c_str()));
        started = true;
    });
    if (!started) {
        return std::unexpected(make_error(ErrorKind::NotRunning, "the iceoryx runtime could not start"));
    }
    return {};
}

}  // namespace drivebus
