// SPDX-License-Identifier: Apache-2.0
#include "rt/kernel_facts.hpp"

#include <sys/utsname.h>
#include <unistd.h>

#include <algorithm>
#include <fstream>
#include <sstream>

namespace drivebus::rt {
namespace {

// A sysfs attribute's first line; nullopt when it cannot be read.
std::optional<std::string> read_line(const std::filesystem::path& path) {
    std::ifstream in(path);
    std::string line;
    if (!in || !std::getline(in, line)) {
        return std::nullopt;
    }
    while (!line.empty() && (line.back() == ' ' || line.back() == '\r')) {
        line.pop_back();
    }
    return line;
}

std::optional<Attribute> attribute(const std::filesystem::path& path) {
    auto value = read_line(path);
    if (!value) {
        return std::nullopt;
    }
    return Attribute{*value, ::access(path.c_str(), W_OK) == 0};
}

// "0-3,6": CPU lists as the kernel prints them.
std::string cpu_list(const std::vector<int>& cpus) {
    std::string out;
    for (std::size_t i = 0; i < cpus.size();) {
        std::size_t j = i;
        while (j + 1 < cpus.size() && cpus[j + 1] == cpus[j] + 1) {
            ++j;
        }
        out += (out.empty() ? "" : ",") + std::to_string(cpus[i]) + (j > i ? "-" + std::to_string(cpus[j]) : "");
        i = j + 1;
    }
    return out;
}

bool preempt_rt(const KernelFacts& k) {
    return k.realtime == "1" || k.version.find("PREEMPT_RT") != std::string::npos;
}

Finding kernel_finding(const KernelFacts& k) {
    if (preempt_rt(k)) {
        return {false, "kernel: PREEMPT_RT (" + k.version +
                           "): interrupt handlers run in threads that can be given real-time priority"};
    }
    return {true, "kernel: not PREEMPT_RT (" + k.version +
                      "): under load, received bytes can reach drivebusd milliseconds after they were on the wire"};
}

Finding worker_finding(const KernelFacts& k) {
    if (!k.unbound_cpumask) {
        return {false, "tty worker (unbound workqueue): its cpumask is not readable"};
    }
    const auto cpus = parse_cpumask(*k.unbound_cpumask);
    if (!cpus) {
        return {false, "tty worker (unbound workqueue): cpumask '" + *k.unbound_cpumask + "' not understood"};
    }
    const std::string where = "tty worker (unbound workqueue, normal priority) on CPUs " + cpu_list(*cpus);
    if (k.bus_cpus.empty()) {
        return {false, where + "; the bus threads on any CPU: it competes with every other task"};
    }
    std::vector<int> bus = k.bus_cpus;
    std::ranges::sort(bus);
    std::vector<int> shared;
    std::ranges::set_intersection(*cpus, bus, std::back_inserter(shared));
    if (shared.empty()) {
        return {true, where + ", none of the bus threads' CPUs " + cpu_list(bus) +
                          ": kept off them, it waits behind the load on the others"};
    }
    if (shared.size() == cpus->size()) {
        return {false, where + ", all of them the bus threads' CPUs " + cpu_list(bus)};
    }
    return {false, where + ", of them the bus threads' " + cpu_list(shared)};
}

std::optional<Finding> latency_timer_finding(const PortFacts& p) {
    if (!p.latency_timer) {
        return std::nullopt;
    }
    const auto& [value, writable] = *p.latency_timer;
    if (value == "1") {
        return Finding{false, p.tty + ": latency_timer 1 ms"};
    }
    if (writable) {
        return Finding{false, p.tty + ": latency_timer " + value + " ms; drivebusd sets 1 ms when it opens the port"};
    }
    return Finding{true, p.tty + ": latency_timer " + value +
                             " ms, not writable: the adapter holds received bytes "
                             "back up to " +
                             value + " ms (a udev rule can set 1)"};
}

std::optional<Finding> rx_trigger_finding(const PortFacts& p) {
    if (!p.rx_trig_bytes) {
        return std::nullopt;
    }
    const auto& [value, writable] = *p.rx_trig_bytes;
    if (value == "1") {
        return Finding{false, p.tty + ": rx_trig_bytes 1"};
    }
    if (writable) {
        return Finding{false,
                       p.tty + ": rx_trig_bytes " + value + "; drivebusd sets the lowest level when it opens the port"};
    }
    return Finding{true, p.tty + ": rx_trig_bytes " + value + ", not writable: received bytes wait in the FIFO for " +
                             value + " of them or its time-out (about 4 characters)"};
}

}  // namespace

std::optional<std::vector<int>> parse_cpumask(std::string_view mask) {
    std::vector<int> cpus;
    int bit = 0;
    for (auto it = mask.rbegin(); it != mask.rend(); ++it) {
        if (*it == ',') {
            continue;
        }
        int digit = 0;
        if (*it >= '0' && *it <= '9') {
            digit = *it - '0';
        } else if (*it >= 'a' && *it <= 'f') {
            digit = *it - 'a' + 10;
        } else if (*it >= 'A' && *it <= 'F') {
            digit = *it - 'A' + 10;
        } else {
            return std::nullopt;
        }
        for (int b = 0; b < 4; ++b, ++bit) {
            if ((digit & (1 << b)) != 0) {
                cpus.push_back(bit);
            }
        }
    }
    if (bit == 0) {
        return std::nullopt;
    }
    return cpus;
}

std::vector<Finding> judge(const KernelFacts& kernel, const PortFacts& port) {
    std::vector<Finding> out{kernel_finding(kernel), worker_finding(kernel)};
    for (auto finding : {latency_timer_finding(port), rx_trigger_finding(port)}) {
        if (finding) {
            out.push_back(std::move(*finding));
        }
    }
    return out;
}

KernelFacts read_kernel_facts(std::vector<int> bus_cpus, const std::filesystem::path& sys) {
    KernelFacts k;
    utsname name{};
    if (::uname(&name) == 0) {
        k.version = name.version;
    }
    k.realtime = read_line(sys / "kernel" / "realtime");
    k.unbound_cpumask = read_line(sys / "devices" / "virtual" / "workqueue" / "cpumask");
    k.bus_cpus = std::move(bus_cpus);
    return k;
}

PortFacts read_port_facts(const std::string& tty, const std::filesystem::path& sysfs_tty) {
    PortFacts p;
    p.tty = tty;
    const auto dir = sysfs_tty / tty;
    // Where ftdi_sio puts it, as serial/tuning.cpp looks for it.
    p.latency_timer = attribute(dir / "device" / "latency_timer");
    if (!p.latency_timer) {
        p.latency_timer = attribute(dir / "device" / ".." / "latency_timer");
    }
    p.rx_trig_bytes = attribute(dir / "rx_trig_bytes");
    return p;
}

}  // namespace drivebus::rt
