// SPDX-License-Identifier: Apache-2.0
// The command line as every drivebus program reads it (CLI11): --help and --version, and a
// mistake as one line, "PROGRAM: WHAT (see --help)", with exit status 2. drivebusctl alone
// words its mistakes otherwise (in JSON with --json).
#pragma once

#include <CLI/CLI.hpp>
#include <functional>
#include <iostream>
#include <optional>
#include <string>
#include <string_view>

#include "drivebus/version.hpp"

namespace drivebus::cli {

inline constexpr int kExitUsage = 2;

// --version: prints the version ("0.1.0") and exits 0.
inline void add_version(CLI::App& app) {
    app.set_version_flag("--version", std::string(DRIVEBUS_VERSION_STRING));
}

// Parses the command line, then runs `check` (rules CLI11 cannot state; it throws a
// CLI::ParseError). Nothing: go on; else the exit status: 0 after --help or --version, 2 after
// a mistake (written on stderr).
[[nodiscard]] inline std::optional<int> parse(CLI::App& app, int argc, char** argv, std::string_view program,
                                              const std::function<void()>& check = {}) {
    try {
        app.parse(argc, argv);
        if (check) {
            check();
        }
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForVersion& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        std::cerr << program << ": " << e.what() << " (see --help)\n";
        return kExitUsage;
    }
    return std::nullopt;
}

}  // namespace drivebus::cli
