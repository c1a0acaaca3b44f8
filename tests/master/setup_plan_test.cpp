// SPDX-License-Identifier: Apache-2.0
// The set-up plan's decisions, fed by hand: what it asks, and what it concludes from each
// answer: selectors written only when they differ, a reset awaited for selectors the drive
// applies after one, and the read block confirmed only when its values can tell.
#include "master/setup_plan.hpp"

#include <gtest/gtest.h>

#include "fixtures.hpp"

namespace drivebus::test {
namespace {

using namespace std::chrono_literals;
using master::SetupNote;
using master::SetupPlan;
using master::SetupState;

class SetupPlanTest : public ::testing::Test {
protected:
    std::shared_ptr<const Profile> atv21 = load("atv21");

    // The pump of the examples: FD00 and FD01 through the read block, optionally FA00 and FA01
    // through the write block.
    SetupPlan plan(bool read_block, bool write_block) {
        auto d = drive("pump", 1, atv21);
        if (read_block) {
            d.polls.push_back(poll(*atv21, {"FD00", "FD01"}, 100ms, true));
        }
        if (write_block) {
            d.write_block = {0xFA00, 0xFA01};
        }
        return SetupPlan(1, *atv21, master::block_setups(d));
    }

    static master::Result words(std::vector<std::uint16_t> values) {
        master::Result r;
        r.outcome = master::Outcome::Ok;
        rtu::ReadHoldingRegistersResponse reply;
        for (const auto v : values) {
            reply.values.push_back(v);
        }
        r.response = reply;
        return r;
    }
    static master::Result written(std::uint16_t reg, std::uint16_t value) {
        master::Result r;
        r.outcome = master::Outcome::Ok;
        r.response = rtu::WriteSingleRegisterResponse{reg, value};
        return r;
    }

    // Asks the plan's next request, checks it reads `reg` (one word), answers `value`.
    static SetupState read(SetupPlan& p, std::uint16_t reg, std::uint16_t value) {
        const auto request = p.next();
        EXPECT_TRUE(request.has_value());
        const auto* r = request ? std::get_if<rtu::ReadHoldingRegisters>(&request->pdu) : nullptr;
        EXPECT_NE(r, nullptr);
        if (r != nullptr) {
            EXPECT_EQ(r->start, reg);
            EXPECT_EQ(r->quantity, 1);
        }
        return p.take(words({value}));
    }
    static SetupState write(SetupPlan& p, std::uint16_t reg, std::uint16_t value) {
        const auto request = p.next();
        const auto* w = request ? std::get_if<rtu::WriteSingleRegister>(&request->pdu) : nullptr;
        EXPECT_NE(w, nullptr);
        if (w != nullptr) {
            EXPECT_EQ(w->address, reg);
            EXPECT_EQ(w->value, value);
        }
        return p.take(written(reg, value));
    }
    static SetupState block(SetupPlan& p, std::vector<std::uint16_t> values) {
        const auto request = p.next();
        const auto* r = request ? std::get_if<rtu::ReadHoldingRegisters>(&request->pdu) : nullptr;
        EXPECT_NE(r, nullptr);
        if (r != nullptr) {
            EXPECT_EQ(r->start, 0x1875);
            EXPECT_EQ(r->quantity, values.size());
        }
        return p.take(words(std::move(values)));
    }
    // The read block's selectors (F875 = 2 for FD00, F876 = 1 for FD01, F877-F879 = 0), as held.
    static void selectors_hold(SetupPlan& p) {
        EXPECT_EQ(read(p, 0x0875, 2), SetupState::Running);
        EXPECT_EQ(read(p, 0x0876, 1), SetupState::Running);
        for (std::uint16_t s = 0x0877; s <= 0x0879; ++s) {
            EXPECT_EQ(read(p, s, 0), SetupState::Running);
        }
    }
    // One confirmation round: block, FD00 and FD01 on their own, block again.
    static SetupState round(SetupPlan& p, std::vector<std::uint16_t> first, std::uint16_t fd00, std::uint16_t fd01,
                            std::vector<std::uint16_t> second) {
        EXPECT_EQ(block(p, std::move(first)), SetupState::Running);
        EXPECT_EQ(read(p, 0xFD00, fd00), SetupState::Running);
        EXPECT_EQ(read(p, 0xFD01, fd01), SetupState::Running);
        return block(p, std::move(second));
    }
};

TEST_F(SetupPlanTest, SelectorsThatHoldAreNotWrittenAndTheBlockConfirmsThem) {
    auto p = plan(true, false);
    selectors_hold(p);
    // FD00 moves (ramping) between the readings: the direct one lies between the block's.
    EXPECT_EQ(round(p, {1000, 0x4400}, 1100, 0x4400, {1200, 0x4400}), SetupState::Done);
    EXPECT_FALSE(p.next().has_value());
}

TEST_F(SetupPlanTest, AValueThatJittersAgreesAStatusWordMustMatch) {
    auto p = plan(true, false);
    selectors_hold(p);
    // FD00 within 2 % of the block's (it is no bit field); FD01 off by one bit does not agree.
    EXPECT_EQ(round(p, {5000, 0x4400}, 5080, 0x4401, {5000, 0x4400}), SetupState::Running);
    EXPECT_EQ(round(p, {5000, 0x4400}, 5080, 0x4400, {5000, 0x4400}), SetupState::Done);
}

TEST_F(SetupPlanTest, ABlockThatReturnsOtherRegistersFailsAfterThreeRounds) {
    auto p = plan(true, false);
    selectors_hold(p);
    EXPECT_EQ(round(p, {0, 0}, 0, 0x4000, {0, 0}), SetupState::Running);
    EXPECT_EQ(round(p, {0, 0}, 0, 0x4000, {0, 0}), SetupState::Running);
    EXPECT_EQ(round(p, {0, 0}, 0, 0x4000, {0, 0}), SetupState::Failed);
    EXPECT_EQ(p.note().kind, SetupNote::Kind::BlockDiffers);
    EXPECT_EQ(p.note().slot, 2);
    EXPECT_EQ(p.note().reg, 0xFD01);
    EXPECT_EQ(p.note().wanted, 0x4000);
    EXPECT_EQ(p.note().held, 0);
    EXPECT_FALSE(p.awaiting_reset());
}

TEST_F(SetupPlanTest, ARefusedOrDifferentSelectorFails) {
    auto p = plan(true, false);
    EXPECT_EQ(read(p, 0x0875, 0), SetupState::Running);
    EXPECT_EQ(write(p, 0x0875, 2), SetupState::Running);
    EXPECT_EQ(read(p, 0x0875, 0), SetupState::Failed);  // read back otherwise
    EXPECT_EQ(p.note().kind, SetupNote::Kind::ReadBack);
    EXPECT_EQ(p.note().reg, 0x0875);
    EXPECT_EQ(p.note().wanted, 2);
    p.restart();
    EXPECT_EQ(read(p, 0x0875, 0), SetupState::Running);
    master::Result refused;
    refused.outcome = master::Outcome::Exception;
    refused.response = rtu::ExceptionResponse{0x06, rtu::ExceptionCode::ServerDeviceBusy};
    ASSERT_TRUE(p.next().has_value());
    EXPECT_EQ(p.take(refused), SetupState::Failed);
    EXPECT_EQ(p.note().kind, SetupNote::Kind::Refused);
    EXPECT_EQ(p.note().exception, 6);
}

// Written selectors of a block that applies them after a reset: the block confirms the new
// selection only where the old one would read otherwise.
TEST_F(SetupPlanTest, AfterAResetTheBlockMustTellTheNewSelectionFromTheOld) {
    auto p = plan(true, false);
    EXPECT_EQ(read(p, 0x0875, 0), SetupState::Running);  // factory: no selection
    EXPECT_EQ(write(p, 0x0875, 2), SetupState::Running);
    EXPECT_EQ(read(p, 0x0875, 2), SetupState::Running);
    EXPECT_EQ(read(p, 0x0876, 0), SetupState::Running);
    EXPECT_EQ(write(p, 0x0876, 1), SetupState::Running);
    EXPECT_EQ(read(p, 0x0876, 1), SetupState::Running);
    for (std::uint16_t s = 0x0877; s <= 0x0879; ++s) {
        EXPECT_EQ(read(p, s, 0), SetupState::Running);
    }
    EXPECT_TRUE(p.awaiting_reset());
    // Not reset: the block reads 0 0 (nothing selected) while FD01 says "ready".
    EXPECT_EQ(round(p, {0, 0}, 0, 0x4000, {0, 0}), SetupState::Running);
    EXPECT_EQ(round(p, {0, 0}, 0, 0x4000, {0, 0}), SetupState::Running);
    EXPECT_EQ(round(p, {0, 0}, 0, 0x4000, {0, 0}), SetupState::AwaitingReset);
    EXPECT_EQ(p.note().kind, SetupNote::Kind::BlockDiffers);

    // A drive whose every value is 0 cannot show which selection is in effect.
    p.restart();
    selectors_hold(p);
    EXPECT_EQ(round(p, {0, 0}, 0, 0, {0, 0}), SetupState::AwaitingReset);
    EXPECT_EQ(p.note().kind, SetupNote::Kind::CannotTell);
    EXPECT_TRUE(p.awaiting_reset());

    // Silent and back: the block can tell, so it still has to.
    p.reset_seen();
    EXPECT_TRUE(p.awaiting_reset());
    p.restart();
    selectors_hold(p);
    EXPECT_EQ(round(p, {0, 0x4000}, 0, 0x4000, {0, 0x4000}), SetupState::Done);
    EXPECT_FALSE(p.awaiting_reset());
    // From then on, agreement is enough.
    p.restart();
    selectors_hold(p);
    EXPECT_EQ(round(p, {0, 0}, 0, 0, {0, 0}), SetupState::Done);
}

// The write block cannot be read: selectors written for it are taken as applied only once the
// drive has been seen off and on (or its fault cleared).
TEST_F(SetupPlanTest, AWriteBlockWrittenWaitsForTheDriveToBeReset) {
    auto p = plan(false, true);
    EXPECT_EQ(read(p, 0x0870, 0), SetupState::Running);
    EXPECT_EQ(write(p, 0x0870, 1), SetupState::Running);
    EXPECT_EQ(read(p, 0x0870, 1), SetupState::Running);
    EXPECT_EQ(read(p, 0x0871, 0), SetupState::Running);
    EXPECT_EQ(write(p, 0x0871, 3), SetupState::Running);
    EXPECT_EQ(read(p, 0x0871, 3), SetupState::AwaitingReset);
    EXPECT_EQ(p.note().kind, SetupNote::Kind::NotApplied);
    EXPECT_EQ(p.note().reg, 0x0870);
    p.restart();
    EXPECT_EQ(read(p, 0x0870, 1), SetupState::Running);
    EXPECT_EQ(read(p, 0x0871, 3), SetupState::AwaitingReset);
    p.reset_seen();
    p.restart();
    EXPECT_EQ(read(p, 0x0870, 1), SetupState::Running);
    EXPECT_EQ(read(p, 0x0871, 3), SetupState::Done);
}

}  // namespace
}  // namespace drivebus::test
