// SPDX-License-Identifier: Apache-2.0
// The start-up check of what the polling asks of the line.
#include "master/line_budget.hpp"

#include <gtest/gtest.h>

#include "fixtures.hpp"

namespace drivebus::test {
namespace {

using namespace std::chrono_literals;

// At 19200 8N1 an ATV21 register is one read: 8 request bytes, 7 reply bytes, two t3.5.
TEST(LineBudget, APollGroupNeedsItsReadsAndTheirSilences) {
    const auto atv21 = load("atv21");
    const auto config = bus();
    const auto timing = rtu::character_timing(config.format).value();
    auto pump = drive("pump", 1, atv21);
    const auto group = poll(*atv21, {"FD00", "FD01"}, 100ms);
    EXPECT_EQ(master::poll_line_time(pump, group, timing), 2 * (timing.character * 15 + 2 * timing.t3_5));
    // Through the indirect block the same two are one read of 2 registers (9 reply bytes).
    const auto block = poll(*atv21, {"FD00", "FD01"}, 100ms, true);
    EXPECT_EQ(master::poll_line_time(pump, block, timing), timing.character * 17 + 2 * timing.t3_5);
}

TEST(LineBudget, WarnsOfAGroupSlowerThanItsPeriodAndOfALineAskedTooMuch) {
    const auto atv21 = load("atv21");
    auto config = bus();
    auto pump = drive("pump", 1, atv21);
    pump.polls.push_back(poll(*atv21, {"FD00", "FD01"}, 100ms));
    config.drives.push_back(pump);
    EXPECT_TRUE(master::line_budget_warnings(config).empty()) << "about 23 ms every 100 ms";

    // The same reads every 10 ms: the group cannot keep its period, nor the line.
    config.drives[0].polls[0].period = 10ms;
    auto lines = master::line_budget_warnings(config);
    ASSERT_EQ(lines.size(), 2U);
    EXPECT_NE(lines[0].find("bus 'test' drive 'pump' poll 'g': its reads take at least 22.9 ms of line time, "
                            "more than its period of 10.0 ms"),
              std::string::npos)
        << lines[0];
    EXPECT_NE(lines[1].find("bus 'test': its poll groups need at least 229% of the line's time"), std::string::npos)
        << lines[1];

    // Three groups that each fit their 25 ms, but not together.
    config.drives[0].polls[0].period = 25ms;
    config.drives[0].polls.push_back(poll(*atv21, {"FE03", "FE04"}, 25ms));
    config.drives[0].polls.push_back(poll(*atv21, {"FD06", "FD07"}, 25ms));
    lines = master::line_budget_warnings(config);
    ASSERT_EQ(lines.size(), 1U);
    EXPECT_NE(lines[0].find("need at least 275% of the line's time"), std::string::npos) << lines[0];
}

}  // namespace
}  // namespace drivebus::test
