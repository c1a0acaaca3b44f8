// SPDX-License-Identifier: Apache-2.0
// The gpio line through libgpiod 2's C++ bindings (Debian 13); gpio_line_gpiod1.cpp is the
// 1.6 one (lib/serial/CMakeLists.txt picks one). libgpiod 2 opens a chip by path only, so the
// name, number or label the configuration may give is resolved here, as 1.6's OPEN_LOOKUP
// did. The bindings report failures by throwing (std::system_error with errno,
// std::invalid_argument, ...); no exception leaves this file.
#include <gpiod.hpp>

#include <algorithm>
#include <exception>
#include <optional>
#include <system_error>

#include "serial/gpio_line.hpp"

namespace drivebus::serial {
namespace {

constexpr const char* kConsumer = "drivebusd";

class Gpiod2Line final : public OutputLine {
public:
    Gpiod2Line(GpioOptions options, gpiod::line_request request)
        : options_(std::move(options)), request_(std::move(request)) {}
    Gpiod2Line(const Gpiod2Line&) = delete;
    Gpiod2Line& operator=(const Gpiod2Line&) = delete;
    Gpiod2Line(Gpiod2Line&&) = delete;
    Gpiod2Line& operator=(Gpiod2Line&&) = delete;

    ~Gpiod2Line() override {
        // Leave the bus free: a released line keeps its last level on most controllers.
        try {
            request_.set_value(options_.line, gpiod::line::value::INACTIVE);
            request_.release();
        } catch (const std::exception&) {  // NOLINT(bugprone-empty-catch): nothing left to tell
        }
    }

    std::expected<void, DirectionError> set(bool active) override {
        try {
            // The logical value: the request's active-low setting inverts it on the pin.
            request_.set_value(options_.line, active ? gpiod::line::value::ACTIVE : gpiod::line::value::INACTIVE);
        } catch (const std::exception& e) {
            return std::unexpected(DirectionError{describe(options_) + ": setting it " +
                                                  (active ? "active" : "inactive") + " failed: " + e.what()});
        }
        return {};
    }

private:
    GpioOptions options_;
    gpiod::line_request request_;
};

bool is_number(const std::string& text) {
    return !text.empty() && std::ranges::all_of(text, [](char c) { return c >= '0' && c <= '9'; });
}

// The device of a chip given as a path, a name in /dev ("gpiochip0"), a number or a label.
// Empty when no chip has that label; a chip that cannot be opened to read its label is a
// failure only if none has it.
std::filesystem::path chip_path(const std::string& chip, const std::vector<std::string>& chips) {
    if (chip.find('/') != std::string::npos) {
        return chip;
    }
    const std::string name = is_number(chip) ? "gpiochip" + chip : chip;
    if (std::ranges::find(chips, name) != chips.end() || name != chip) {
        return "/dev/" + name;
    }
    std::optional<std::system_error> unreadable;
    for (const auto& candidate : chips) {
        try {
            if (gpiod::chip("/dev/" + candidate).get_info().label() == chip) {
                return "/dev/" + candidate;
            }
        } catch (const std::system_error& e) {
            unreadable.emplace(e);
        }
    }
    if (unreadable) {
        throw *unreadable;
    }
    return {};
}

}  // namespace

std::expected<std::unique_ptr<OutputLine>, DirectionError> open_gpio_line(const GpioOptions& options) {
    const auto fail = [&](const std::string& what, bool permanent = false) {
        return std::unexpected(DirectionError{describe(options) + ": " + what, permanent});
    };
    std::optional<gpiod::chip> chip;
    try {
        const auto path = chip_path(options.chip, gpio_chips());
        if (path.empty()) {
            return fail(no_such_chip(gpio_chips()), true);
        }
        chip.emplace(path);
    } catch (const std::system_error& e) {
        if (is_no_chip(e.code().value())) {
            return fail(no_such_chip(gpio_chips()), true);
        }
        return fail(std::string("cannot open the chip: ") + e.code().message());
    } catch (const std::exception& e) {
        return fail(std::string("cannot open the chip: ") + e.what());
    }
    try {
        const auto info = chip->get_info();
        if (options.line >= info.num_lines()) {
            return fail("no such line (" + info.name() + " \"" + info.label() + "\" has " +
                            std::to_string(info.num_lines()) + " lines)",
                        true);
        }
        const auto line = chip->get_line_info(options.line);
        if (line.used()) {
            const auto holder = line.consumer();
            return fail(holder.empty() ? std::string("busy (in use)") : "busy (used by \"" + holder + "\")");
        }
        gpiod::line_settings settings;
        settings.set_direction(gpiod::line::direction::OUTPUT)
            .set_active_low(options.active_low)
            .set_output_value(gpiod::line::value::INACTIVE);  // the bus stays free until the first request
        gpiod::line_config config;
        config.add_line_settings(options.line, settings);
        auto request = chip->prepare_request().set_consumer(kConsumer).set_line_config(config).do_request();
        // The request holds its own descriptor: the chip may close.
        return std::make_unique<Gpiod2Line>(options, std::move(request));
    } catch (const std::system_error& e) {
        return fail(std::string("cannot request the line: ") + e.code().message());
    } catch (const std::exception& e) {
        return fail(std::string("cannot request the line: ") + e.what());
    }
}

}  // namespace drivebus::serial
