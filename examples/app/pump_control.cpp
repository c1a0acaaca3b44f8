// SPDX-License-Identifier: Apache-2.0
// An application on libdrivebus: runs an Altivar at a set frequency for a while, prints what
// the drive reports as it ramps, then stops it with a ramp.
//
//   pump_control [--bus NAME] [--drive NAME] [--hz 30] [--seconds 3]
//
// While it runs it holds the drive's control lease, and its control loop renews it with
// keep_alive() on every pass; if the loop hangs or the process is killed, nothing renews it and
// drivebusd applies the drive's fallback (by default a ramp stop) when the lease runs out.
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>
#include <thread>

#include "drivebus/altivar.hpp"
#include "drivebus/client.hpp"

namespace {

struct Args {
    std::string bus;
    std::string drive = "pump";
    double hz = 30.0;
    double seconds = 3.0;
};

Args parse(int argc, char** argv) {
    Args a;
    for (int i = 1; i + 1 < argc; i += 2) {
        const std::string_view key = argv[i];
        const char* value = argv[i + 1];
        if (key == "--bus") {
            a.bus = value;
        } else if (key == "--drive") {
            a.drive = value;
        } else if (key == "--hz") {
            a.hz = std::atof(value);
        } else if (key == "--seconds") {
            a.seconds = std::atof(value);
        } else {
            std::fprintf(stderr, "pump_control: unknown option %s\n", argv[i]);
            std::exit(2);
        }
    }
    return a;
}

int fail(const drivebus::Error& e) {
    std::fprintf(stderr, "pump_control: %s\n", e.message.c_str());
    return 1;
}

}  // namespace

int main(int argc, char** argv) {
    const Args args = parse(argc, argv);
    drivebus::ConnectOptions options;
    options.application = "pump_control";
    auto bus = drivebus::Bus::connect(args.bus, options);
    if (!bus) {
        return fail(bus.error());
    }
    auto drive = bus->drive(args.drive);
    if (!drive) {
        return fail(drive.error());
    }
    const drivebus::Altivar pump(*drive);
    if (auto ok = pump.set_frequency(args.hz); !ok) {
        return fail(ok.error());
    }
    if (auto ok = pump.run_forward(); !ok) {
        return fail(ok.error());
    }
    const auto until = drivebus::Clock::now() + std::chrono::duration<double>(args.seconds);
    std::uint64_t seen = 0;
    while (drivebus::Clock::now() < until) {
        // One pass of the control loop: at least a few per lease time (1 s by default), whether or
        // not a new snapshot came.
        auto snapshot = drive->wait_snapshot(std::chrono::milliseconds(100), seen);
        if (!snapshot && snapshot.error().kind != drivebus::ErrorKind::NoReply) {
            return fail(snapshot.error());
        }
        // This loop is alive: say so. Only this renews the lease between writes.
        if (auto ok = drive->keep_alive(); !ok) {
            return fail(ok.error());
        }
        if (!snapshot) {
            continue;
        }
        seen = snapshot->sequence;
        const auto state = drivebus::decode_state(*drive->profile(), *snapshot);
        std::printf("%s: %s %.2f Hz%s%s\n", args.drive.c_str(), state.running ? "running" : "stopped",
                    state.output_hz.value_or(0.0), state.fault ? ", fault " : "",
                    state.fault ? state.fault_name.c_str() : "");
    }
    if (auto ok = pump.stop(); !ok) {
        return fail(ok.error());
    }
    if (auto ok = drive->release_control(); !ok) {
        return fail(ok.error());
    }
    std::printf("%s: stop sent\n", args.drive.c_str());
    return 0;
}
