// SPDX-License-Identifier: Apache-2.0
#include "supervisor.hpp"

#include <algorithm>
#include <utility>

#include "bus/line_opener.hpp"
#include "config/reload.hpp"
#include "ipc/bus_service.hpp"
#include "log/log.hpp"
#include "master/comm_timeout.hpp"
#include "master/line_budget.hpp"
#include "rt/memory.hpp"

namespace drivebus::daemon {
namespace {

std::string fmt_mib(const std::string& before, std::size_t kib) {
    const auto tenths = (kib * 10 + 512) / 1024;
    return before + std::to_string(tenths / 10) + "." + std::to_string(tenths % 10) + " MiB";
}

}  // namespace

std::string describe(const config::Config& c) {
    std::size_t drives = 0;
    for (const auto& b : c.buses) {
        drives += b.drives.size();
    }
    return std::to_string(c.buses.size()) + (c.buses.size() == 1 ? " bus, " : " buses, ") + std::to_string(drives) +
           (drives == 1 ? " drive" : " drives");
}

// Warnings a configuration still leaves.
void warn(const config::Config& c) {
    for (const auto& line : config::start_up_warnings(c)) {
        log::warning(line);
    }
    for (const auto& bus : c.buses) {
        for (const auto& line : master::line_budget_warnings(bus)) {
            log::warning(line);
        }
        for (const auto& line : master::comm_timeout_warnings(bus)) {
            log::warning(line);
        }
    }
}

// The warnings, and the permanent misconfigurations of the lines (a GPIO chip that is not
// there, RS485 the driver lacks): the first of those is the error.
std::expected<void, std::string> check_and_warn(const config::Config& c) {
    warn(c);
    for (const auto& bus : c.buses) {
        if (auto usable = bus::check_line(bus); !usable) {
            return std::unexpected(usable.error());
        }
    }
    return {};
}

Supervisor::Supervisor(config::Config config, std::filesystem::path file, config::LoadOptions options)
    : config_(std::move(config)), file_(std::move(file)), options_(std::move(options)) {}

Supervisor::~Supervisor() {
    stop();
}

std::unique_ptr<Supervisor> Supervisor::start(config::Config config, std::filesystem::path file,
                                              config::LoadOptions options) {
    const auto rt = config.realtime;
    auto ipc_host = ipc::Host::start(config, "drivebusd-" + std::to_string(::getpid()));
    if (!ipc_host) {
        log::error(ipc_host.error());
        return nullptr;
    }
    for (const auto& b : config.buses) {
        if (const auto pid = ipc::bus_served_elsewhere(b.name)) {
            log::error("bus " + b.name + " is already served by another drivebusd (pid " + std::to_string(*pid) +
                           "); stop it first, or give this bus another name",
                       {.bus = b.name});
            return nullptr;
        }
    }
    log::notice("shared memory: " + (*ipc_host)->describe());
    for (const auto& warning : (*ipc_host)->warnings()) {
        log::warning("shared memory: " + warning);
    }
    for (const auto& note : (*ipc_host)->notes()) {
        log::notice("shared memory: " + note);
    }

    std::unique_ptr<Supervisor> s(new Supervisor(std::move(config), std::move(file), std::move(options)));
    s->host_ = std::move(*ipc_host);
    s->kernel_ = rt::read_kernel_facts(rt.mode == config::RealtimeMode::Off ? std::vector<int>{} : rt.cpus);
    for (const auto& b : s->config_.buses) {
        auto started = start_bus(b, rt, s->host_->layout(), s->kernel_, {});
        if (!started) {
            log::error(started.error());
            s->stop();
            return nullptr;
        }
        s->buses_.push_back(std::move(*started));
    }
    // Locked once the shared memory is mapped and every thread runs, so that what is locked is
    // what this process has, less iceoryx's management segment (see rt/memory.hpp).
    if (rt.mode != config::RealtimeMode::Off && rt.lock_memory) {
        const std::vector<std::string> left_out{ipc::Host::management_segment()};
        auto locked = rt::lock_memory(left_out);
        if (!locked) {
            if (rt.mode == config::RealtimeMode::Required) {
                log::error(locked.error() + "; [realtime] mode is required");
                s->stop();
                return nullptr;
            }
            log::warning(locked.error() + "; running best-effort");
        } else {
            log::info(fmt_mib("memory locked: ", locked->locked_kib) +
                      fmt_mib(" (VmLck); left unlocked: the iceoryx management segment, ", locked->left_out_kib) +
                      " mapped");
        }
    }
    return s;
}

// The configuration read and checked again; applied only whole. A bus whose settings changed is
// restarted with its leases; the others, and every client, go on.
void Supervisor::reload() {
    log::notice("reload: reading " + file_.string());
    auto next = config::load_config(file_, options_);
    if (!next) {
        log::error("reload refused, the running configuration stays: " + next.error().message);
        return;
    }
    auto plan = config::plan_reload(config_, *next);
    if (!plan) {
        log::error("reload refused, the running configuration stays: " + plan.error());
        return;
    }
    if (host_->embedded()) {
        auto needed = ipc::plan_layout(*next);
        if (!needed) {
            log::error("reload refused, the running configuration stays: " + needed.error());
            return;
        }
        if (const auto short_of = ipc::layout_shortfall(host_->layout(), *needed)) {
            log::error("reload refused, the running configuration stays: " + *short_of +
                       "; restart drivebusd to apply it (systemctl restart drivebusd)");
            return;
        }
    }
    if (auto checked = check_and_warn(*next); !checked) {
        log::error("reload refused, the running configuration stays: " + checked.error());
        return;
    }
    for (const auto& name : plan->start) {
        if (const auto pid = ipc::bus_served_elsewhere(name)) {
            log::error("reload refused, the running configuration stays: bus " + name +
                       " is already served by another drivebusd (pid " + std::to_string(*pid) + ")");
            return;
        }
    }
    const auto in = [](const std::vector<std::string>& names, const std::string& name) {
        return std::ranges::find(names, name) != names.end();
    };
    std::map<std::string, ipc::Carried> carried;
    std::vector<RunningBus> kept;
    std::vector<RunningBus> dropped;
    for (auto& b : buses_) {
        if (in(plan->keep, b.config->name)) {
            kept.push_back(std::move(b));
        } else if (in(plan->stop, b.config->name)) {
            dropped.push_back(std::move(b));
        } else {
            carried[b.config->name] = restart_bus(b);
        }
    }
    end_buses(dropped);
    buses_ = std::move(kept);
    const auto now_rt = next->realtime;
    for (const auto& settings : next->buses) {
        if (in(plan->keep, settings.name)) {
            continue;
        }
        auto started = start_bus(settings, now_rt, host_->layout(), kernel_, carried[settings.name]);
        if (!started) {
            // Only a refused real-time priority, with mode = "required": nothing else differs
            // from the start, which was granted it.
            log::error("reload: bus " + settings.name + " not started: " + started.error(), {.bus = settings.name});
            continue;
        }
        buses_.push_back(std::move(*started));
    }
    // Each bus in the order of the configuration.
    std::ranges::sort(buses_, {}, [&](const RunningBus& b) {
        return std::ranges::find(next->buses, b.config->name, &config::BusConfig::name) - next->buses.begin();
    });
    log::notice("reload: " + config::describe(*plan) + "; running: " + describe(*next));
    config_ = std::move(*next);
    heartbeats_.clear();
}

bool Supervisor::heartbeat() {
    bool alive = true;
    for (const auto& b : buses_) {
        const std::uint64_t beat = b.loop->heartbeat();
        if (const auto it = heartbeats_.find(b.config->name); it != heartbeats_.end() && beat == it->second) {
            alive = false;
            log::error("bus " + b.config->name + ": its event loop has not run for a second", {.bus = b.config->name});
        }
        heartbeats_[b.config->name] = beat;
    }
    return alive;
}

std::string Supervisor::status_line() const {
    std::string out;
    for (const auto& b : buses_) {
        const auto s = b.loop->status();
        if (!out.empty()) {
            out += "; ";
        }
        out += b.config->name + (s.up ? " up" : " down") + ", " + std::to_string(b.service->drives_online()) + "/" +
               std::to_string(b.config->drives.size()) + " drives online, " + std::to_string(s.counters.replies) +
               " replies, " + std::to_string(s.counters.timeouts) + " timeouts";
    }
    return out;
}

void Supervisor::stop() {
    end_buses(buses_);
    buses_.clear();
}

}  // namespace drivebus::daemon
