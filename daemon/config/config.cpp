// SPDX-License-Identifier: Apache-2.0
// parse_config() and load_config(): the TOML text, [realtime], every [[bus]], and the checks
// that span buses. The first error is the one reported.
#include "config/config.hpp"

#include <algorithm>
#include <array>
#include <cstdlib>
#include <fstream>
#include <map>
#include <span>
#include <sstream>
#include <system_error>

#include "drivebus/shm.hpp"
#include "read.hpp"

namespace drivebus::config {
namespace {

namespace fs = std::filesystem;

constexpr std::uintmax_t kMaxFileSize = 1U << 20;  // a configuration is a few KiB

// In the order of RealtimeMode's and RouDiMode's enumerators, which the tables read by index.
constexpr std::array<std::string_view, 3> kRealtimeModes = {"off", "best-effort", "required"};
constexpr std::array<std::string_view, 3> kRouDiModes = {"auto", "embedded", "external"};

std::unexpected<ConfigError> fail(std::string message) {
    return std::unexpected(ConfigError{std::move(message)});
}

// One file's [[bus]] tables, read into `config` with that file's errors.
struct BusSource {
    detail::Section* root;
    detail::Errors* errors;
};

// toml++ prints a table the same way whatever file or place it came from: the bus's settings
// as written, for a reload to tell which buses changed.
std::string settings_text(const toml::table& table) {
    std::ostringstream out;
    out << toml::toml_formatter(table);
    return out.str();
}

void read_buses(std::span<const BusSource> sources, const LoadOptions& options, Config& config) {
    detail::ProfileCache profiles(options);
    detail::DriveNames drive_names;
    std::map<std::string, std::string> names;  // bus name -> itself, for the message
    std::map<fs::path, std::string> devices;   // device -> bus name
    std::size_t index = 0;
    for (const auto& source : sources) {
        auto& errors = *source.errors;
        for (const auto* table : source.root->tables("bus")) {
            auto bus = detail::read_bus(*table, index++, errors, profiles, drive_names);
            const auto where =
                bus.name.empty() ? detail::entry_name("bus", index - 1) : "bus " + detail::in_quotes(bus.name);
            if (!bus.name.empty() && !names.emplace(bus.name, bus.name).second) {
                errors.add(where, "name " + detail::in_quotes(bus.name) + " is already another bus");
            }
            if (!bus.device.empty()) {
                if (const auto [it, fresh] = devices.emplace(bus.device, bus.name); !fresh) {
                    errors.add(where, "device " + detail::in_quotes(bus.device.string()) + " is already bus " +
                                          detail::in_quotes(it->second));
                }
            }
            if (options.state_dir && !table->contains("state_dir")) {
                bus.state_dir = *options.state_dir;
            }
            bus.settings = settings_text(*table);
            config.buses.push_back(std::move(bus));
        }
    }
    if (index == 0 && !sources.front().errors->any()) {
        sources.front().errors->add("", "no [[bus]]: drivebusd needs at least one bus");
    }
}

}  // namespace

std::expected<std::optional<fs::path>, ConfigError> state_dir_from_environment() {
    const char* value = std::getenv("DRIVEBUS_STATE_DIR");  // NOLINT(concurrency-mt-unsafe): at start-up
    if (value == nullptr || *value == '\0') {
        return std::nullopt;
    }
    fs::path dir(value);
    if (!dir.is_absolute()) {
        return fail("DRIVEBUS_STATE_DIR " + detail::in_quotes(value) + " is not an absolute path");
    }
    return dir;
}

namespace detail {
namespace {

static_assert(in_enum_order(kRealtimeModes, {RealtimeMode::Off, RealtimeMode::BestEffort, RealtimeMode::Required}));
static_assert(in_enum_order(kRouDiModes, {RouDiMode::Auto, RouDiMode::Embedded, RouDiMode::External}));

using namespace std::chrono_literals;
using RealtimeKeys = Keys<RealtimeConfig>;
using IpcKeys = Keys<IpcConfig>;

void read_cpus(Section& s, const toml::table& /*table*/, const Key<RealtimeConfig>& key, RealtimeConfig& realtime) {
    const auto cpus = s.integers(key.name, key.range.lo, key.range.hi).value_or(std::vector<std::int64_t>{});
    for (std::size_t i = 0; i < cpus.size(); ++i) {
        const auto cpu = static_cast<int>(cpus[i]);
        if (std::ranges::find(realtime.cpus, cpu) != realtime.cpus.end()) {
            s.fail("cpus[" + std::to_string(i) + "] " + std::to_string(cpu) + " is listed twice");
        }
        realtime.cpus.push_back(cpu);
    }
}

constexpr Table<RealtimeConfig, 5> kRealtimeKeys = {
    RealtimeKeys::choice<&RealtimeConfig::mode>(
        "mode", kRealtimeModes,
        "off: normal scheduling; best-effort: SCHED_FIFO and locked memory when allowed; required: or no start"),
    RealtimeKeys::integer<&RealtimeConfig::priority>("priority", 1, 99, "SCHED_FIFO priority of the bus threads"),
    // CPU_SETSIZE is 1024.
    RealtimeKeys::custom("cpus", "array of integers", Need::Optional, integers(0, 1023, "each"), read_cpus,
                         RealtimeKeys::shown<&RealtimeConfig::cpus>, "CPU affinity of the bus threads; none: any"),
    RealtimeKeys::boolean<&RealtimeConfig::lock_memory>("lock_memory",
                                                        "lock the memory drivebusd uses, once it is set up"),
    RealtimeKeys::duration<&RealtimeConfig::send_spin>(
        "send_spin", 0ns, 1ms, "wake this long before a request is due and spin on the clock for the rest; 0: off"),
};

// POSIX portable user and group names, as useradd takes them.
template <std::string IpcConfig::* Group>
void read_group(Section& s, const toml::table& /*table*/, const Key<IpcConfig>& key, IpcConfig& ipc) {
    auto name = s.string(key.name);
    if (!name) {
        return;
    }
    const bool ok = !name->empty() && (*name)[0] != '-' && std::ranges::all_of(*name, [](char c) {
        return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-' ||
               c == '.';
    });
    if (!ok) {
        s.fail(std::string(key.name) + " " + in_quotes(*name) + " is not a valid group name");
    } else {
        fits_shm(s, key.name, *name, shm::kGroupSize, "a group name");
    }
    ipc.*Group = std::move(*name);
}

// The last of the three groups: the rule that they differ is checked as soon as all are read.
void read_daemon_group(Section& s, const toml::table& table, const Key<IpcConfig>& key, IpcConfig& ipc) {
    read_group<&IpcConfig::daemon_group>(s, table, key, ipc);
    if (ipc.daemon_group == ipc.watch_group || ipc.daemon_group == ipc.control_group ||
        ipc.watch_group == ipc.control_group) {
        s.fail("watch_group, control_group and daemon_group must be three different groups");
    }
}

constexpr Table<IpcConfig, 5> kIpcKeys = {
    IpcKeys::choice<&IpcConfig::roudi>("roudi", kRouDiModes,
                                       "where RouDi runs: joined if one answers, else embedded; embedded; joined"),
    IpcKeys::custom("watch_group", "string", Need::Optional, words("a group name"), read_group<&IpcConfig::watch_group>,
                    IpcKeys::shown<&IpcConfig::watch_group>, "members may subscribe to snapshots and status"),
    IpcKeys::custom("control_group", "string", Need::Optional, words("a group name"),
                    read_group<&IpcConfig::control_group>, IpcKeys::shown<&IpcConfig::control_group>,
                    "members may send requests"),
    IpcKeys::custom("daemon_group", "string", Need::Optional, words("a group name"), read_daemon_group,
                    IpcKeys::shown<&IpcConfig::daemon_group>, "drivebusd's user alone: the writer of its segment"),
    IpcKeys::integer<&IpcConfig::max_clients>("max_clients", 1, 200, "sizes the embedded RouDi's shared memory"),
};

}  // namespace

RealtimeConfig read_realtime(const toml::table& table, Errors& errors) {
    Section s(table, "realtime", errors);
    allow_only(s, table, {}, kRealtimeKeys);
    RealtimeConfig realtime;
    read_keys(s, table, kRealtimeKeys, realtime);
    return realtime;
}

IpcConfig read_ipc(const toml::table& table, Errors& errors) {
    Section s(table, "ipc", errors);
    allow_only(s, table, {}, kIpcKeys);
    IpcConfig ipc;
    read_keys(s, table, kIpcKeys, ipc);
    return ipc;
}

std::vector<SectionReference> top_reference() {
    return {described("[realtime]", kRealtimeKeys), described("[ipc]", kIpcKeys)};
}

}  // namespace detail

std::expected<Config, ConfigError> parse_config(std::span<const ConfigText> files, const LoadOptions& options) {
    if (files.empty()) {
        return fail("no configuration file");
    }
    // Every file is parsed before any is read, so that a syntax error anywhere is the error.
    std::vector<toml::table> roots(files.size());
    for (std::size_t i = 0; i < files.size(); ++i) {
        auto root = settings::parse_toml(files[i].text, files[i].source);
        if (!root) {
            return std::unexpected(ConfigError{std::move(root.error())});
        }
        roots[i] = std::move(*root);
    }
    // One Errors per file, so that a problem is named in the file where it is.
    std::vector<detail::Errors> errors;
    std::vector<detail::Section> sections;
    errors.reserve(files.size());
    sections.reserve(files.size());
    for (std::size_t i = 0; i < files.size(); ++i) {
        errors.emplace_back(files[i].source);
        sections.emplace_back(roots[i], "", errors[i]);
    }
    Config config;
    config.source = fs::path(files.front().source);
    sections.front().allow_only({"realtime", "ipc", "bus"});
    if (const auto* realtime = sections.front().table("realtime")) {
        config.realtime = detail::read_realtime(*realtime, errors.front());
    }
    if (const auto* ipc = sections.front().table("ipc")) {
        config.ipc = detail::read_ipc(*ipc, errors.front());
    }
    std::vector<BusSource> sources;
    for (std::size_t i = 0; i < files.size(); ++i) {
        if (i > 0) {
            // [realtime] and [ipc] concern the whole daemon: one place, the main file.
            sections[i].allow_only({"bus"});
            config.fragments.emplace_back(files[i].source);
        }
        sources.push_back({&sections[i], &errors[i]});
    }
    read_buses(sources, options, config);
    for (const auto& e : errors) {
        if (e.any()) {
            return std::unexpected(ConfigError{e.message()});
        }
    }
    return config;
}

std::expected<Config, ConfigError> parse_config(std::string_view text, std::string_view source,
                                                const LoadOptions& options) {
    const std::array files = {ConfigText{std::string(source), std::string(text)}};
    return parse_config(files, options);
}

fs::path fragment_directory(const fs::path& file) {
    return file.parent_path() / (file.stem().string() + ".d");
}

std::expected<Config, ConfigError> load_config(const fs::path& file, const LoadOptions& options) {
    auto text = settings::read_small_file(file, kMaxFileSize, "a configuration");
    if (!text) {
        return fail(text.error());
    }
    std::vector<ConfigText> files{{file.string(), std::move(*text)}};
    const auto dir = fragment_directory(file);
    std::error_code ec;
    if (fs::is_directory(dir, ec)) {
        std::vector<fs::path> fragments;
        for (const auto& entry : fs::directory_iterator(dir, ec)) {
            // Only *.toml: an editor's backup or dpkg's .dpkg-old beside a fragment is not read.
            if (entry.path().extension() == ".toml" && entry.is_regular_file(ec)) {
                fragments.push_back(entry.path());
            }
        }
        if (ec) {
            return fail(dir.string() + ": " + ec.message());
        }
        std::ranges::sort(fragments);
        for (const auto& f : fragments) {
            auto fragment = settings::read_small_file(f, kMaxFileSize, "a configuration fragment");
            if (!fragment) {
                return fail(fragment.error());
            }
            files.push_back({f.string(), std::move(*fragment)});
        }
    }
    return parse_config(files, options);
}

std::string_view to_string(LeaseFallback fallback) noexcept {
    switch (fallback) {
    case LeaseFallback::Hold: return "hold";
    case LeaseFallback::Stop: return "stop";
    case LeaseFallback::Freewheel: return "freewheel";
    }
    return "?";
}

std::string_view to_string(RouDiMode mode) noexcept {
    return kRouDiModes.at(static_cast<std::size_t>(mode));
}

std::string_view to_string(DirectionMode mode) noexcept {
    switch (mode) {
    case DirectionMode::Kernel: return "kernel";
    case DirectionMode::Gpio: return "gpio";
    case DirectionMode::Rts: return "rts";
    case DirectionMode::None: return "none";
    }
    return "?";
}

std::string_view to_string(EchoMode mode) noexcept {
    switch (mode) {
    case EchoMode::Off: return "off";
    case EchoMode::On: return "on";
    case EchoMode::Auto: return "auto";
    }
    return "?";
}

}  // namespace drivebus::config
