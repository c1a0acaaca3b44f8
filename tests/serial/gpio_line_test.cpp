// SPDX-License-Identifier: Apache-2.0
// open_gpio_line through the libgpiod this build found (2 on Debian 13, 1.6 on Debian 12):
// a chip that is not there, however the configuration names it, is one permanent line. A
// machine without GPIO chips (this one) cannot show a line, its bounds or its holder; those
// are for a machine with a chip.
#include <gtest/gtest.h>

#include <string>

#include "serial/gpio_line.hpp"

namespace drivebus::serial {
namespace {

class GpioLineTest : public ::testing::TestWithParam<const char*> {
protected:
    void SetUp() override {
        if (!gpio_chips().empty()) {
            GTEST_SKIP() << "this machine has GPIO chips";
        }
    }
};

TEST_P(GpioLineTest, AChipThatIsNotThereIsOnePermanentLine) {
    const GpioOptions options{.chip = GetParam(), .line = 3, .active_low = true};
    const auto line = open_gpio_line(options);
    ASSERT_FALSE(line.has_value());
    EXPECT_EQ(line.error().message,
              std::string("gpio ") + GetParam() + " line 3: no such GPIO chip (no /dev/gpiochip* on this machine)");
    EXPECT_TRUE(line.error().permanent);
}

// A name, a number, a path, a path to a device that is not a GPIO chip, a label.
INSTANTIATE_TEST_SUITE_P(Names, GpioLineTest,
                         ::testing::Values("gpiochip0", "0", "/dev/gpiochip0", "/dev/null", "pinctrl-bcm2711"));

TEST(GpioLineNames, NoChipsAndSomeChipsAreSaidApart) {
    EXPECT_EQ(no_such_chip({}), "no such GPIO chip (no /dev/gpiochip* on this machine)");
    EXPECT_EQ(no_such_chip({"gpiochip0", "gpiochip1"}), "no such GPIO chip (there are gpiochip0, gpiochip1)");
}

}  // namespace
}  // namespace drivebus::serial
