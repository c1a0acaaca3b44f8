// SPDX-License-Identifier: Apache-2.0
// The gpio line through libgpiod 1.6's C++ bindings (Debian 12); gpio_line_gpiod2.cpp is the
// libgpiod 2 one (lib/serial/CMakeLists.txt picks one). The bindings report failures by
// throwing std::system_error (errno) or std::out_of_range; no exception leaves this file.
#include <gpiod.hpp>

#include <exception>
#include <system_error>

#include "serial/gpio_line.hpp"

namespace drivebus::serial {
namespace {

constexpr const char* kConsumer = "drivebusd";

class GpiodLine final : public OutputLine {
public:
    GpiodLine(GpioOptions options, gpiod::chip chip, gpiod::line line)
        : options_(std::move(options)), chip_(std::move(chip)), line_(std::move(line)) {}
    GpiodLine(const GpiodLine&) = delete;
    GpiodLine& operator=(const GpiodLine&) = delete;
    GpiodLine(GpiodLine&&) = delete;
    GpiodLine& operator=(GpiodLine&&) = delete;

    ~GpiodLine() override {
        // Leave the bus free: a released line keeps its last level on most controllers.
        try {
            line_.set_value(0);
            line_.release();
        } catch (const std::exception&) {  // NOLINT(bugprone-empty-catch): nothing left to tell
        }
    }

    std::expected<void, DirectionError> set(bool active) override {
        try {
            // The logical value: the request's ACTIVE_LOW flag inverts it on the pin.
            line_.set_value(active ? 1 : 0);
        } catch (const std::exception& e) {
            return std::unexpected(DirectionError{describe(options_) + ": setting it " +
                                                  (active ? "active" : "inactive") + " failed: " + e.what()});
        }
        return {};
    }

private:
    GpioOptions options_;
    gpiod::chip chip_;
    gpiod::line line_;
};

}  // namespace

std::expected<std::unique_ptr<OutputLine>, DirectionError> open_gpio_line(const GpioOptions& options) {
    const auto fail = [&](const std::string& what, bool permanent = false) {
        return std::unexpected(DirectionError{describe(options) + ": " + what, permanent});
    };
    gpiod::chip chip;
    try {
        // OPEN_LOOKUP: a label, a name ("gpiochip0"), a path ("/dev/gpiochip0") or a number.
        chip.open(options.chip, gpiod::chip::OPEN_LOOKUP);
    } catch (const std::system_error& e) {
        if (is_no_chip(e.code().value())) {
            return fail(no_such_chip(gpio_chips()), true);
        }
        return fail(std::string("cannot open the chip: ") + e.code().message());
    } catch (const std::exception& e) {
        return fail(std::string("cannot open the chip: ") + e.what());
    }
    if (options.line >= chip.num_lines()) {
        return fail("no such line (" + chip.name() + " \"" + chip.label() + "\" has " +
                        std::to_string(chip.num_lines()) + " lines)",
                    true);
    }
    try {
        gpiod::line line = chip.get_line(options.line);
        if (line.is_used()) {
            const auto holder = line.consumer();
            return fail(holder.empty() ? std::string("busy (in use)") : "busy (used by \"" + holder + "\")");
        }
        gpiod::line_request request;
        request.consumer = kConsumer;
        request.request_type = gpiod::line_request::DIRECTION_OUTPUT;
        if (options.active_low) {
            request.flags = gpiod::line_request::FLAG_ACTIVE_LOW;
        }
        line.request(request, 0);  // inactive: the bus stays free until the first request
        return std::make_unique<GpiodLine>(options, std::move(chip), std::move(line));
    } catch (const std::system_error& e) {
        return fail(std::string("cannot request the line: ") + e.code().message());
    } catch (const std::exception& e) {
        return fail(std::string("cannot request the line: ") + e.what());
    }
}

}  // namespace drivebus::serial
