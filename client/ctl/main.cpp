// SPDX-License-Identifier: Apache-2.0
// drivebusctl: looks at and commands the drives drivebusd runs (docs/drivebusctl.md).
//
//   drivebusctl [--bus NAME] [--json] [--timeout DURATION] [--profile-dir DIR] COMMAND ...
//     list | status [DRIVE] | read DRIVE REG [COUNT] | write DRIVE REG VALUE... [--take-over] [--deadline D]
//     identify DRIVE | watch [--interval DURATION] | scan [--from A] [--to B] [--register R]
//     udev-rule [DEVICE] [--name N] [--group G] [--by-path] [--start UNIT] [--properties FILE]...
//               [--gpio-chip CHIP]... [--config FILE]      (needs no drivebusd)
//     line-check [--config FILE]         (drivebusd --check-line, with drivebusd stopped)
//
// Exit status: 0 ok, 1 the drive failed the request, 2 usage, 3 rejected or unsupported,
// 4 not permitted, 5 drivebusd or the bus unavailable, 6 queue full, 7 timed out and withdrawn
// (never sent), 8 timed out after it was sent (outcome unknown).
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "as_root.hpp"
#include "commands.hpp"
#include "drivebus/version.hpp"
#include "drivebusd_run.hpp"
#include "format.hpp"
#include "steps.hpp"
#include "udev_command.hpp"

using namespace drivebus;

namespace {

int usage_error(const ctl::Options& options, const std::string& message) {
    Error e;
    e.kind = ErrorKind::InvalidArgument;
    e.message = message + " (see drivebusctl --help)";
    return ctl::report(options, e);
}

// A DURATION option as milliseconds, or the usage error.
bool duration(const ctl::Options& options, const std::string& name, const std::string& text,
              std::chrono::milliseconds& out, int& status) {
    const auto parsed = ctl::option_duration(text);
    if (!parsed) {
        status = usage_error(options, name + ": " + parsed.error());
        return false;
    }
    out = *parsed;
    return true;
}

// The line check is drivebusd's (drivebusd --check-line): its configuration reader, its port
// and direction control and its bus thread, which a libdrivebus client does not link. This
// runs it in place of drivebusctl; DRIVEBUSD names another drivebusd (a build tree's).
int run_line_check(const ctl::Options& options, const std::string& config) {
    if (options.json) {
        return usage_error(options,
                           "line-check: no --json output (its report is for people; its exit code for scripts)");
    }
    const std::string program = ctl::drivebusd_program();
    std::vector<std::string> args = {program, "--config", config, "--check-line"};
    if (!options.bus.empty()) {
        args.insert(args.end(), {"--bus", options.bus});
    }
    if (!options.profile_dir.empty()) {
        args.insert(args.end(), {"--profile-dir", options.profile_dir});
    }
    std::vector<char*> argv;
    for (auto& arg : args) {
        argv.push_back(arg.data());
    }
    argv.push_back(nullptr);
    std::fflush(stdout);
    ::execv(program.c_str(), argv.data());
    std::fprintf(stderr,
                 "drivebusctl: line-check: cannot run %s: %s; the line check is drivebusd's (install the "
                 "drivebusd package, or name it with DRIVEBUSD=PATH)\n",
                 program.c_str(), std::strerror(errno));
    return 5;  // drivebusd unavailable
}

}  // namespace

int main(int argc, char** argv) {
    ctl::Options options;
    std::string timeout = "2s";
    CLI::App app{"drivebusctl: look at and command the drives that drivebusd runs"};
    app.set_version_flag("--version", std::string(DRIVEBUS_VERSION_STRING));
    app.require_subcommand(1);
    app.fallthrough();
    app.add_option("--bus", options.bus, "the bus (default: the only bus drivebusd announces)");
    app.add_flag("--json", options.json, "machine-readable output: one JSON document on stdout");
    app.add_option("--timeout", timeout, "request timeout, like 500ms or 2s (default 2s)");
    app.add_option("--profile-dir", options.profile_dir, "where drive profiles (TYPE.toml) are read from")
        ->check(CLI::ExistingDirectory);

    auto* list = app.add_subcommand("list", "buses and their drives");

    std::string drive;
    auto* status = app.add_subcommand("status", "the bus's status, or a drive's latest snapshot");
    status->add_option("DRIVE", drive, "drive name or address");

    std::string reg;
    std::uint16_t count = 1;
    auto* read = app.add_subcommand("read", "read registers on the bus");
    read->add_option("DRIVE", drive, "drive name or address")->required();
    read->add_option("REG", reg, "register: profile name (FD00) or number (decimal or 0x hex)")->required();
    read->add_option("COUNT", count, "how many registers from REG (default 1)");

    std::vector<std::string> values;
    bool take_over = false;
    auto* write = app.add_subcommand("write", "write registers (one value: FC06, several: FC16)");
    write->add_option("DRIVE", drive, "drive name or address")->required();
    write->add_option("REG", reg, "register: profile name (FA01) or number")->required();
    write->add_option("VALUE", values, "raw (300, 0x12C) or with the register's unit (30Hz, '30.5 Hz')")->required();
    write->add_flag("--take-over", take_over, "take the control lease from the client that holds it");
    std::string deadline;
    write->add_option("--deadline", deadline,
                      "not on the wire within this time (like 200ms), the write is dropped, never sent (exit 9)");

    auto* identify = app.add_subcommand("identify", "vendor, product code and revision (FC43/14)");
    identify->add_option("DRIVE", drive, "drive name or address")->required();

    std::string interval = "200ms";
    auto* watch = app.add_subcommand("watch", "a live table of every drive on the bus; q quits");
    watch->add_option("--interval", interval, "refresh interval (default 200ms)");

    int from = 1;
    int to = 32;
    std::string probe_register = "0";
    auto* scan = app.add_subcommand("scan", "probe addresses: who answers on the bus?");
    scan->add_option("--from", from, "first address (default 1)");
    scan->add_option("--to", to, "last address (default 32)");
    scan->add_option("--register", probe_register, "the register each probe reads (default 0)");

    ctl::UdevRuleArgs udev;
    auto* udev_rule = app.add_subcommand(
        "udev-rule", "print a udev rule that names one adapter, and gives GPIO chips to drivebusd (no daemon needed)");
    udev_rule->add_option(
        "DEVICE", udev.device,
        "the adapter's or chip's device: /dev/ttyUSB0, ttyAMA0, /dev/serial/by-id/..., /dev/gpiochip0");
    udev_rule->add_option("--name", udev.choice.name, "the stable name, /dev/drivebus/NAME (default rs485-0)");
    udev_rule->add_option("--group", udev.choice.group, "the port's group (default drivebusd, the daemon's own)");
    udev_rule->add_flag("--by-path", udev.choice.by_path,
                        "USB: name the adapter by the USB port it is plugged into, not by its serial number");
    udev_rule->add_option("--start", udev.choice.start_unit,
                          "start this unit when the adapter appears (ENV{SYSTEMD_WANTS}); default: none");
    udev_rule
        ->add_option("--properties", udev.properties,
                     "read a device's properties from FILE (udevadm info --query=property output) instead of udev")
        ->expected(1)
        ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
    udev_rule
        ->add_option("--gpio-chip", udev.gpio_chips, "also give this GPIO chip (gpiochipN or label) to group drivebusd")
        ->expected(1)
        ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
    udev_rule->add_option("--config", udev.config,
                          "also give the GPIO chip of each direction = \"gpio\" bus of this drivebusd.toml");

    std::string line_config = "/etc/drivebus/drivebusd.toml";
    auto* line_check = app.add_subcommand(
        "line-check",
        "with drivebusd stopped: open each bus's line as drivebusd does, show its RS485 or GPIO driver enable and "
        "tuning, read each drive once (runs drivebusd --check-line)");
    line_check->add_option("--config", line_config, "drivebusd's configuration (default /etc/drivebus/drivebusd.toml)");

    try {
        app.parse(argc, argv);
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForAllHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForVersion& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        return usage_error(options, e.what());
    }

    if (udev_rule->parsed()) {
        udev.profile_dir = options.profile_dir;
        return ctl::run_udev_rule(udev);
    }
    if (line_check->parsed()) {
        return run_line_check(options, line_config);
    }
    int bad = 0;
    if (!duration(options, "--timeout", timeout, options.timeout, bad)) {
        return bad;
    }
    // Every other command connects to drivebusd: root does it as an ordinary user (as_root.hpp).
    if (const auto became = ctl::leave_root(); !became) {
        return ctl::report(options, ctl::error_of(ErrorKind::NotPermitted,
                                                  "run by root, drivebusctl acts as an ordinary user and found none: " +
                                                      became.error() + "; run it as a member of drivebus's groups"));
    }
    if (list->parsed()) {
        return ctl::run_list(options);
    }
    if (status->parsed()) {
        return ctl::run_status(options, drive);
    }
    if (read->parsed()) {
        return ctl::run_read(options, drive, reg, count);
    }
    if (write->parsed()) {
        WriteOptions write_options;
        write_options.take_over = take_over;
        if (!deadline.empty()) {
            std::chrono::milliseconds by{};
            if (!duration(options, "--deadline", deadline, by, bad)) {
                return bad;
            }
            write_options.deadline = by;
        }
        return ctl::run_write(options, drive, reg, values, write_options);
    }
    if (identify->parsed()) {
        return ctl::run_identify(options, drive);
    }
    if (watch->parsed()) {
        std::chrono::milliseconds every{};
        if (!duration(options, "--interval", interval, every, bad)) {
            return bad;
        }
        return ctl::run_watch(options, every);
    }
    if (scan->parsed()) {
        return ctl::run_scan(options, from, to, probe_register);
    }
    return usage_error(options, "no command");
}
