// SPDX-License-Identifier: Apache-2.0
#include "ipc/host.hpp"

#include <grp.h>
#include <sys/stat.h>
#include <unistd.h>

#include <fmt/format.h>
#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <mutex>
#include <optional>
#include <set>
#include <stop_token>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "drivebus/shm.hpp"
#include "iceoryx_hoofs/error_handling/error_handling.hpp"
#include "iceoryx_hoofs/log/logmanager.hpp"
#include "iceoryx_posh/iceoryx_posh_config.hpp"
#include "iceoryx_posh/internal/roudi/roudi.hpp"
#include "iceoryx_posh/roudi/iceoryx_roudi_components.hpp"
#include "iceoryx_posh/runtime/posh_runtime.hpp"
#include "iceoryx_posh/runtime/posh_runtime_single_process.hpp"
#include "ipc/held_locks.hpp"
#include "ipc/leftovers.hpp"
#include "ipc/registrants.hpp"
#include "ipc/seal.hpp"
#include "log/log.hpp"
#include "sys/local.hpp"
#include "sys/posix.hpp"

namespace drivebus::ipc {
namespace {

// A chunk is the payload plus iceoryx's chunk header (40 bytes), rounded up.
constexpr std::uint32_t kSmallChunk = 1024;  // Response, Request
constexpr std::uint32_t kLargeChunk = 4096;  // DriveSnapshot, BusStatus
static_assert(sizeof(shm::Response) + 64 <= kSmallChunk && sizeof(shm::Request) + 64 <= kSmallChunk);
static_assert(sizeof(shm::DriveSnapshot) + 64 <= kLargeChunk && sizeof(shm::BusStatus) + 64 <= kLargeChunk);

// Queue depths the publishers and servers use (bus_service.cpp keeps to these).
constexpr std::uint32_t kSubscriberQueue = 2;
constexpr std::uint32_t kResponseQueue = 16;  // iceoryx 2.0's most per client
constexpr std::uint32_t kRequestQueue = 256;  // per server

bool group_exists(const std::string& name) {
    return ::getgrnam(name.c_str()) != nullptr;
}

std::string primary_group() {
    if (const auto* g = ::getgrgid(::getegid())) {
        return g->gr_name;
    }
    return std::to_string(::getegid());
}

std::uint32_t drive_count(const config::Config& config) {
    std::uint32_t n = 0;
    for (const auto& bus : config.buses) {
        n += static_cast<std::uint32_t>(bus.drives.size());
    }
    return n;
}

// Every publisher keeps its history chunk, each subscriber's queue may hold kSubscriberQueue,
// and a few are in flight.
std::vector<MemPool> publication_pools(const config::Config& config) {
    const auto clients = static_cast<std::uint32_t>(config.ipc.max_clients);
    const auto publishers = drive_count(config) + static_cast<std::uint32_t>(config.buses.size());
    const std::uint32_t large = publishers * (1 + clients * kSubscriberQueue + 2);
    const std::uint32_t small = static_cast<std::uint32_t>(config.buses.size()) * clients * (kResponseQueue + 4);
    return {{kSmallChunk, small}, {kLargeChunk, large}};
}

std::vector<MemPool> request_pools(const config::Config& config) {
    const auto clients = static_cast<std::uint32_t>(config.ipc.max_clients);
    const std::uint32_t count = static_cast<std::uint32_t>(config.buses.size()) * (kRequestQueue + clients * 4);
    return {{kSmallChunk, count}};
}

std::uint64_t bytes_of(const Layout& layout) {
    std::uint64_t total = 0;
    for (const auto& s : layout.segments) {
        for (const auto& p : s.pools) {
            total += static_cast<std::uint64_t>(p.size + 64) * p.count;
        }
    }
    return total;
}

// FATAL iceoryx errors abort by default; drivebusd ends with one line instead.
void on_iceoryx_error(const iox::Error error, const std::function<void()>& callback, const iox::ErrorLevel level) {
    if (callback) {
        callback();
    }
    if (level == iox::ErrorLevel::FATAL) {
        log::error(fmt::format("iceoryx: fatal error {}", iox::ErrorHandler::toString(error)));
        std::fflush(stderr);
        std::_Exit(1);
    }
    log::warning(fmt::format("iceoryx: {}", iox::ErrorHandler::toString(error)));
}

}  // namespace

// The segments of a grouped layout, each writable by its writer group only (seal.hpp).
std::expected<void, std::string> seal_all(const Layout& layout) {
    if (!layout.grouped) {
        return {};
    }
    for (const auto& segment : layout.segments) {
        if (auto sealed = seal_segment(segment); !sealed) {
            return std::unexpected(fmt::format("could not make segment {} writable by group {} only: {}",
                                               segment_path(segment), segment.writer_group, sealed.error()));
        }
    }
    return {};
}

// RouDi, telling drivebusd who registers, keeps alive and says goodbye (registrants.hpp), and
// listing the ports' locks under its own lock.
class WatchedRouDi final : public iox::roudi::RouDi {
public:
    WatchedRouDi(iox::roudi::RouDiMemoryInterface& memory, iox::roudi::PortManager& ports, Registrants& registrants)
        : RouDi(memory, ports,
                RoudiStartupParameters{iox::roudi::MonitoringMode::ON, /*killProcessesInDestructor=*/false,
                                       RuntimeMessagesThreadStart::DEFER_START}),
          registrants_(registrants),
          sees_all_(proc_shows_everyone()) {
        // Only now: every message, the first REG too, reaches this processMessage().
        startProcessRuntimeMessagesThread();
    }
    // Its threads call processMessage(): they end before this part of it does.
    ~WatchedRouDi() override { shutdown(); }
    WatchedRouDi(const WatchedRouDi&) = delete;
    WatchedRouDi& operator=(const WatchedRouDi&) = delete;
    WatchedRouDi(WatchedRouDi&&) = delete;
    WatchedRouDi& operator=(WatchedRouDi&&) = delete;

    // Every port's lock, listed while RouDi's process manager is held: it alone creates and
    // removes ports. Waits as long as RouDi holds it.
    std::vector<pthread_mutex_t*> locks(iox::roudi::PortPool& pool) {
        auto held = m_prcMgr.getScopeGuard();
        return port_locks(pool);
    }

protected:
    void processMessage(const iox::runtime::IpcMessage& message, const iox::runtime::IpcMessageType& cmd,
                        const iox::RuntimeName_t& name) noexcept override {
        const std::string runtime(name.c_str());
        const auto now = Registrants::Clock::now();
        if (cmd == iox::runtime::IpcMessageType::REG && message.getNumberOfElements() == 6) {
            // Before RouDi answers: no port of it exists before drivebusd knows of it.
            std::uint32_t pid = 0;
            uid_t uid = 0;
            std::int64_t sent = 0;
            (void)parseRegisterMessage(message, pid, uid, sent);
            const auto ticks = boot_ticks_now();
            registrants_.registered(runtime, static_cast<pid_t>(pid),
                                    judge_registrant(static_cast<pid_t>(pid), uid, ticks, "/proc", sees_all_), now);
        } else if (cmd != iox::runtime::IpcMessageType::TERMINATION) {
            registrants_.heard(runtime, now);
        }
        RouDi::processMessage(message, cmd, name);
        if (cmd == iox::runtime::IpcMessageType::TERMINATION) {
            registrants_.left(runtime);
        }
    }

private:
    Registrants& registrants_;
    bool sees_all_;
};

// The components create the segments; RouDi, once constructed, answers on its socket.
// This process's runtime is a member too, declared last: it goes first, and says goodbye to a
// RouDi that still listens. (initRuntime()'s runtime is a static that outlives every object
// of main(); at exit it would send its TERMINATION to a RouDi already gone, and iceoryx logs
// that as two errors on every clean stop.)
// The reaper frees the port locks killed clients left held (held_locks.hpp) well before RouDi's
// monitoring (1.5 s without a keep-alive) cleans up after them and would wait on those locks,
// and only while every registered runtime is a process of drivebusd's PID namespace
// (registrants.hpp). The walker lists the locks under RouDi's lock; when RouDi holds that lock
// for long (its clean-up waits on a held lock), no port comes or goes, and the reaper works
// from the walker's last list.
struct Host::Embedded {
    explicit Embedded(const iox::RouDiConfig_t& config)
        : components(config),
          registrants(std::chrono::nanoseconds(iox::runtime::PROCESS_KEEP_ALIVE_TIMEOUT.toNanoseconds())) {}
    void serve() {
        roudi.emplace(components.rouDiMemoryManager, components.portManager, registrants);
        if (auto pool = components.rouDiMemoryManager.portPool(); pool.has_value()) {
            walker = std::jthread([this, p = pool.value()](const std::stop_token& stop) { walk(*p, stop); });
            reaper = std::jthread([this](const std::stop_token& stop) { reap(stop); });
        }
    }
    // Wakes at the period, or at once when asked to stop (the predicate never holds: it is there
    // for the stop token). False once asked to stop.
    static bool pause(const std::stop_token& stop) {
        std::mutex mutex;
        std::condition_variable_any woken;
        std::unique_lock lock(mutex);
        (void)woken.wait_for(lock, stop, kReapPeriod, [] { return false; });
        return !stop.stop_requested();
    }
    void walk(iox::roudi::PortPool& pool, const std::stop_token& stop) {
        do {
            auto now = roudi->locks(pool);
            const std::lock_guard lock(listed_mutex);
            listed = std::move(now);
        } while (pause(stop));
    }
    void reap(const std::stop_token& stop) {
        HeldLockReaper reaper_of_locks;
        std::set<std::pair<std::string, pid_t>> told;
        bool refused = false;
        while (pause(stop)) {
            if (const auto refusal = registrants.refusal()) {
                // Nothing suspected while refused counts towards a later sweep.
                reaper_of_locks.forget();
                refused = true;
                if (told.emplace(refusal->runtime, refusal->pid).second) {
                    log::warning(
                        fmt::format("iceoryx: locks a killed client leaves held are not freed while runtime "
                                    "'{}' (pid {}) is connected: {}",
                                    refusal->runtime, refusal->pid, refusal->reason));
                }
                continue;
            }
            if (refused) {
                refused = false;
                log::info(
                    "iceoryx: every connected runtime is a process drivebusd can judge: locks a killed client "
                    "leaves held are freed again");
            }
            std::vector<pthread_mutex_t*> locks;
            {
                const std::lock_guard lock(listed_mutex);
                locks = listed;
            }
            if (const auto freed = reaper_of_locks.sweep(locks); freed > 0) {
                log::warning(fmt::format("iceoryx: freed {} lock(s) that a killed client had left held", freed));
            }
        }
    }
    static constexpr std::chrono::milliseconds kReapPeriod{100};
    iox::roudi::IceOryxRouDiComponents components;
    Registrants registrants;
    std::mutex listed_mutex;
    std::vector<pthread_mutex_t*> listed;  // the walker's last list
    std::optional<WatchedRouDi> roudi;
    std::optional<iox::runtime::PoshRuntimeSingleProcess> runtime;
    std::jthread walker;  // declared after the RouDi it asks: stops before it goes
    std::jthread reaper;  // declared last: stops first
};

std::expected<Layout, std::string> plan_layout(const config::Config& config) {
    const auto& ipc = config.ipc;
    const std::array<const std::string*, 3> groups = {&ipc.watch_group, &ipc.control_group, &ipc.daemon_group};
    const auto present = std::ranges::count_if(groups, [](const std::string* g) { return group_exists(*g); });
    Layout layout;
    if (present == 0) {
        const auto own = primary_group();
        layout.segments.push_back({own, own, publication_pools(config)});
        auto& pools = layout.segments.back().pools;
        pools.front().count += request_pools(config).front().count;
        return layout;
    }
    if (present != 3) {
        std::string missing;
        for (const auto* g : groups) {
            if (!group_exists(*g)) {
                missing += (missing.empty() ? "" : ", ") + *g;
            }
        }
        return std::unexpected(
            fmt::format("[ipc]: group(s) {} do not exist while the others do; create them "
                        "(systemd-sysusers drivebus.conf) or name existing groups in [ipc]",
                        missing));
    }
    const auto mine = sys::groups_of_this_user();
    if (std::ranges::find(mine, ipc.daemon_group) == mine.end()) {
        return std::unexpected(
            fmt::format("[ipc]: this user is not in daemon_group {}, so it could not publish; "
                        "run drivebusd as the drivebus user or add the group "
                        "(usermod -aG {} USER)",
                        ipc.daemon_group, ipc.daemon_group));
    }
    if (std::ranges::find(mine, ipc.control_group) != mine.end()) {
        return std::unexpected(
            fmt::format("[ipc]: this user is in control_group {} as well as daemon_group {}; "
                        "iceoryx allows one writable segment per user",
                        ipc.control_group, ipc.daemon_group));
    }
    layout.grouped = true;
    layout.control_group = ipc.control_group;
    layout.segments.push_back({ipc.watch_group, ipc.daemon_group, publication_pools(config)});
    layout.segments.push_back({ipc.daemon_group, ipc.control_group, request_pools(config)});
    return layout;
}

std::optional<std::string> layout_shortfall(const Layout& running, const Layout& needed) {
    if (running.grouped != needed.grouped || running.segments.size() != needed.segments.size()) {
        return "the groups of [ipc] exist now as they did not at start (or the reverse)";
    }
    for (std::size_t s = 0; s < needed.segments.size(); ++s) {
        const auto& have = running.segments[s];
        const auto& want = needed.segments[s];
        if (have.reader_group != want.reader_group || have.writer_group != want.writer_group ||
            have.pools.size() != want.pools.size()) {
            return "the shared memory's segments differ from those set up at start";
        }
        for (std::size_t p = 0; p < want.pools.size(); ++p) {
            if (want.pools[p].size > have.pools[p].size || want.pools[p].count > have.pools[p].count) {
                return fmt::format(
                    "the buses and drives need {} chunks of {} bytes in the segment of group {}, the shared memory "
                    "set up at start has {}",
                    want.pools[p].count, want.pools[p].size, want.writer_group, have.pools[p].count);
            }
        }
    }
    return std::nullopt;
}

bool roudi_running() {
    std::string path = iox::platform::IOX_UDS_SOCKET_PATH_PREFIX;
    path += iox::roudi::IPC_CHANNEL_ROUDI_NAME;
    return sys::datagram_socket_answers(path).has_value();
}

std::expected<std::unique_ptr<Host>, std::string> Host::start(const config::Config& config, const std::string& name) {
    static auto handler = iox::ErrorHandler::setTemporaryErrorHandler(on_iceoryx_error);
    // iceoryx prints on std::clog, std::cerr and (its RouDi) std::cout, with colour escapes:
    // from here on those lines go through drivebusd's log, and stdout stays empty. Its logger
    // says nothing under warnings.
    log::route_standard_streams();
    iox::log::LogManager::GetLogManager().SetDefaultLogLevel(iox::log::LogLevel::kWarn,
                                                             iox::log::LogLevelOutput::kHideLogLevel);
    auto layout = plan_layout(config);
    if (!layout) {
        return std::unexpected(layout.error());
    }
    std::unique_ptr<Host> host(new Host());
    host->layout_ = std::move(*layout);
    const bool running = roudi_running();
    switch (config.ipc.roudi) {
    case config::RouDiMode::Embedded:
        if (running) {
            return std::unexpected(
                "[ipc] roudi = \"embedded\", but a RouDi already runs (/tmp/roudi answers): "
                "another drivebusd or iox-roudi; stop it, or set roudi = \"external\" or \"auto\"");
        }
        break;
    case config::RouDiMode::External:
        if (!running) {
            return std::unexpected(
                "[ipc] roudi = \"external\", but no RouDi answers on /tmp/roudi: start "
                "drivebus-roudi.service (iox-roudi), or set roudi = \"auto\"");
        }
        break;
    case config::RouDiMode::Auto: break;
    }
    if (!running) {
        std::vector<std::string> segments;
        for (const auto& segment : host->layout_.segments) {
            segments.push_back(segment.writer_group);
        }
        if (auto in_the_way = roudi_in_the_way(segments)) {
            return std::unexpected(*in_the_way);
        }
        iox::RouDiConfig_t roudi_config;
        for (const auto& segment : host->layout_.segments) {
            iox::mepoo::MePooConfig pools;
            for (const auto& p : segment.pools) {
                pools.addMemPool({p.size, p.count});
            }
            roudi_config.m_sharedMemorySegments.push_back(
                {iox::posix::PosixGroup::string_t(iox::cxx::TruncateToCapacity, segment.reader_group.c_str()),
                 iox::posix::PosixGroup::string_t(iox::cxx::TruncateToCapacity, segment.writer_group.c_str()), pools});
        }
        roudi_config.iox::config::RouDiConfig::setDefaults();
        host->roudi_ = std::make_unique<Embedded>(roudi_config);
        // Before RouDi answers anybody, so that no client has opened a segment yet.
        if (auto sealed = seal_all(host->layout_); !sealed) {
            return std::unexpected(sealed.error());
        }
        host->roudi_->serve();
        // RouDi's thread makes its socket under a temporary process-wide umask; a runtime
        // started meanwhile in this process does the same, and the two can leave the socket
        // without group write (clients then get EACCES). Wait for it, then set its mode.
        const auto deadline = sys::now() + std::chrono::seconds(5);
        while (!roudi_running() && sys::now() < deadline) {
            std::this_thread::sleep_for(std::chrono::milliseconds(1));
        }
        const std::string socket =
            std::string(iox::platform::IOX_UDS_SOCKET_PATH_PREFIX) + iox::roudi::IPC_CHANNEL_ROUDI_NAME;
        if (::chmod(socket.c_str(), 0660) != 0) {
            return std::unexpected("the embedded RouDi's socket " + socket + " did not appear");
        }
    }
    if (running) {
        // The system RouDi made the segments; drivebusd's user owns them when the unit runs it
        // as that user (drivebus-roudi.service), and then can seal them.
        if (auto sealed = seal_all(host->layout_); !sealed) {
            host->warnings_.push_back(sealed.error() + "; run the RouDi as drivebusd's user (drivebus-roudi.service)");
        }
    }
    if (const auto removed = remove_stale_client_sockets(); !removed.empty()) {
        std::string list;
        for (std::size_t i = 0; i < removed.size() && i < 5; ++i) {
            list += " " + removed[i];
        }
        host->notes_.push_back(fmt::format("removed the sockets of {} iceoryx client(s) that were killed:{}{}",
                                           removed.size(), list, removed.size() > 5 ? " ..." : ""));
    }
    const iox::RuntimeName_t runtime_name(iox::cxx::TruncateToCapacity, name.c_str());
    if (host->roudi_) {
        host->roudi_->runtime.emplace(runtime_name);
    } else {
        iox::runtime::PoshRuntime::initRuntime(runtime_name);
    }
    return host;
}

Host::~Host() = default;

bool Host::embedded() const noexcept {
    return roudi_ != nullptr;
}

std::string Host::management_segment() {
    return std::string("/dev/shm/") + iox::roudi::SHM_NAME;
}

std::string Host::describe() const {
    const double mib = static_cast<double>(bytes_of(layout_)) / (1024.0 * 1024.0);
    std::string text =
        embedded() ? fmt::format("embedded RouDi, {} segment(s), {:.1f} MiB of chunks", layout_.segments.size(), mib)
                   : std::string("system RouDi (external)");
    if (layout_.grouped) {
        text += fmt::format("; watchers: group {}, requests: group {}", layout_.segments.front().reader_group,
                            layout_.control_group);
    } else {
        text += fmt::format("; groups not set up: any process of group {} may watch and send requests",
                            layout_.segments.front().writer_group);
    }
    return text;
}

}  // namespace drivebus::ipc
