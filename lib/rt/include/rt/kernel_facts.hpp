// SPDX-License-Identifier: Apache-2.0
// What limits exact framing on the kernel's side, as far as drivebusd can read it, for the log
// at start-up: the master only sees bytes when the kernel delivers them, and a worker thread at
// normal priority (flush_to_ldisc on the unbound workqueue) stands between the UART and the
// reader. Reading is one function, judging another (pure, tested with made-up values).
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace drivebus::rt {

struct KernelFacts {
    std::string version;                         // uname -v: "#1 SMP PREEMPT_RT Debian ..."
    std::optional<std::string> realtime;         // /sys/kernel/realtime: "1" on a PREEMPT_RT kernel
    std::optional<std::string> unbound_cpumask;  // /sys/devices/virtual/workqueue/cpumask: "f"
    std::vector<int> bus_cpus;                   // [realtime] cpus of the bus threads; empty: any
};

// A sysfs attribute of the port: its value, and whether drivebusd may write it.
struct Attribute {
    std::string value;
    bool writable = false;
};

struct PortFacts {
    std::string tty;                         // the kernel's name: "ttyUSB0"
    std::optional<Attribute> latency_timer;  // FTDI adapters, in ms
    std::optional<Attribute> rx_trig_bytes;  // 8250 UARTs with a FIFO
};

struct Finding {
    bool against_framing = false;  // a notice: this setting works against exact framing
    std::string text;
};

// One finding per fact (the kernel, the tty worker's CPUs, and the port's latency_timer and
// rx_trig_bytes where the port has them).
[[nodiscard]] std::vector<Finding> judge(const KernelFacts& kernel, const PortFacts& port);

// The CPUs of a sysfs cpumask ("f", "00000000,00000005"); nullopt when it is not one.
[[nodiscard]] std::optional<std::vector<int>> parse_cpumask(std::string_view mask);

// `sys` stands for /sys, `sysfs_tty` for /sys/class/tty (the tests give other trees).
[[nodiscard]] KernelFacts read_kernel_facts(std::vector<int> bus_cpus, const std::filesystem::path& sys = "/sys");
[[nodiscard]] PortFacts read_port_facts(const std::string& tty,
                                        const std::filesystem::path& sysfs_tty = "/sys/class/tty");

}  // namespace drivebus::rt
