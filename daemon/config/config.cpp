// parse_config() and load_config(): the TOML text, [realtime], every [[bus]], and the checks
// that span buses. The first error is the one reported.
#include "config/config.hpp"

#include <algorithm>
#include <array>
#include <fstream>
#include <map>
#include <system_error>

#include "drivebus/shm.hpp"
#include "read.hpp"

namespace drivebus::config {
namespace {

namespace fs = std::filesystem;

constexpr std::uintmax_t kMaxFileSize = 1U << 20;  // a configuration is a few KiB

constexpr std::array<std::string_view, 3> kRealtimeModes = {"off", "best-effort", "required"};
constexpr std::array<std::string_view, 3> kRouDiModes = {"auto", "embedded", "external"};

std::unexpected<ConfigError> fail(std::string message) {
    return std::unexpected(ConfigError{std::move(message)});
}

ConfigError syntax_error(std::string_view source, const toml::parse_error& e) {
    std::string line = std::string(source) + ": line " + std::to_string(e.source().begin.line) + ", column " +
                       std::to_string(e.source().begin.column) + ": ";
    for (const char c : e.description()) {
        line += (c == '\n' || c == '\r') ? ' ' : c;
    }
    return ConfigError{std::move(line)};
}

void read_buses(detail::Section& root, detail::Errors& errors, const LoadOptions& options, Config& config) {
    const auto tables = root.tables("bus");
    if (tables.empty() && !errors.any()) {
        errors.add("", "no [[bus]]: drivebusd needs at least one bus");
        return;
    }
    detail::ProfileCache profiles(options);
    detail::DriveNames drive_names;
    std::map<std::string, std::string> names;  // bus name -> itself, for the message
    std::map<fs::path, std::string> devices;   // device -> bus name
    for (std::size_t i = 0; i < tables.size(); ++i) {
        auto bus = detail::read_bus(*tables[i], i, errors, profiles, drive_names);
        const auto where = bus.name.empty() ? detail::entry_name("bus", i) : "bus " + detail::in_quotes(bus.name);
        if (!bus.name.empty() && !names.emplace(bus.name, bus.name).second) {
            errors.add(where, "name " + detail::in_quotes(bus.name) + " is already another bus");
        }
        if (!bus.device.empty()) {
            if (const auto [it, fresh] = devices.emplace(bus.device, bus.name); !fresh) {
                errors.add(where, "device " + detail::in_quotes(bus.device.string()) + " is already bus " +
                                      detail::in_quotes(it->second));
            }
        }
        config.buses.push_back(std::move(bus));
    }
}

}  // namespace

namespace detail {

RealtimeConfig read_realtime(const toml::table& table, Errors& errors) {
    Section s(table, "realtime", errors);
    s.allow_only({"mode", "priority", "cpus", "lock_memory", "send_spin"});
    RealtimeConfig realtime;
    if (const auto mode = choice(s, "mode", kRealtimeModes)) {
        static constexpr std::array<RealtimeMode, 3> kValues = {RealtimeMode::Off, RealtimeMode::BestEffort,
                                                                RealtimeMode::Required};
        realtime.mode = kValues.at(*mode);
    }
    realtime.priority = static_cast<int>(s.integer("priority", 1, 99).value_or(realtime.priority));
    // CPU_SETSIZE is 1024.
    const auto cpus = s.integers("cpus", 0, 1023).value_or(std::vector<std::int64_t>{});
    for (std::size_t i = 0; i < cpus.size(); ++i) {
        const auto cpu = static_cast<int>(cpus[i]);
        if (std::ranges::find(realtime.cpus, cpu) != realtime.cpus.end()) {
            s.fail("cpus[" + std::to_string(i) + "] " + std::to_string(cpu) + " is listed twice");
        }
        realtime.cpus.push_back(cpu);
    }
    realtime.lock_memory = s.boolean("lock_memory").value_or(realtime.lock_memory);
    realtime.send_spin = duration(s, table, "send_spin", Duration{}, std::chrono::milliseconds(1))
                             .value_or(realtime.send_spin);
    return realtime;
}

IpcConfig read_ipc(const toml::table& table, Errors& errors) {
    Section s(table, "ipc", errors);
    s.allow_only({"roudi", "watch_group", "control_group", "daemon_group", "max_clients"});
    IpcConfig ipc;
    if (const auto mode = choice(s, "roudi", kRouDiModes)) {
        static constexpr std::array<RouDiMode, 3> kValues = {RouDiMode::Auto, RouDiMode::Embedded,
                                                             RouDiMode::External};
        ipc.roudi = kValues.at(*mode);
    }
    const auto group = [&](std::string_view key, std::string& out) {
        if (auto name = s.string(key)) {
            // POSIX portable user and group names, as useradd takes them.
            const bool ok = !name->empty() && (*name)[0] != '-' &&
                            std::ranges::all_of(*name, [](char c) {
                                return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                                       c == '_' || c == '-' || c == '.';
                            });
            if (!ok) {
                s.fail(std::string(key) + " " + in_quotes(*name) + " is not a valid group name");
            } else {
                fits_shm(s, key, *name, shm::kGroupSize, "a group name");
            }
            out = std::move(*name);
        }
    };
    group("watch_group", ipc.watch_group);
    group("control_group", ipc.control_group);
    group("daemon_group", ipc.daemon_group);
    if (ipc.daemon_group == ipc.watch_group || ipc.daemon_group == ipc.control_group ||
        ipc.watch_group == ipc.control_group) {
        s.fail("watch_group, control_group and daemon_group must be three different groups");
    }
    ipc.max_clients = static_cast<std::size_t>(s.integer("max_clients", 1, 200).value_or(32));
    return ipc;
}

}  // namespace detail

std::expected<Config, ConfigError> parse_config(std::string_view text, std::string_view source,
                                                const LoadOptions& options) {
    toml::table root;
    try {
        root = toml::parse(text, std::string(source));
    } catch (const toml::parse_error& e) {
        return std::unexpected(syntax_error(source, e));
    }
    detail::Errors errors(source);
    detail::Section s(root, "", errors);
    s.allow_only({"realtime", "ipc", "bus"});
    Config config;
    config.source = fs::path(source);
    if (const auto* realtime = s.table("realtime")) {
        config.realtime = detail::read_realtime(*realtime, errors);
    }
    if (const auto* ipc = s.table("ipc")) {
        config.ipc = detail::read_ipc(*ipc, errors);
    }
    read_buses(s, errors, options, config);
    if (errors.any()) {
        return std::unexpected(ConfigError{errors.error().message});
    }
    return config;
}

std::expected<Config, ConfigError> load_config(const fs::path& file, const LoadOptions& options) {
    auto text = profile_detail::read_small_file(file, kMaxFileSize, "a configuration");
    if (!text) {
        return fail(text.error());
    }
    return parse_config(*text, file.string(), options);
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
