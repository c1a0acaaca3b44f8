// SPDX-License-Identifier: Apache-2.0
// How drivebusd sets a drive's indirect blocks up and makes sure the drive applies them.
//
// Each selector is read first and written only if it differs (the drive keeps them in EEPROM),
// then read back. A selector that takes effect only after a reset (the ATV21's F870-F879) does
// not change the block when it is written: the plan then waits for the reset. The read block
// is then confirmed by what it returns: read through the block, each slot's register read on
// its own, the block read again; each slot must lie between its two block readings. While a
// reset is awaited, the confirmation must also tell the new selection from the one before (a
// slot whose value differs between them), or it proves nothing.
//
// Pure: the scheduler sends the requests and hands back each result; time is not involved.
// Everything is sized at construction: the bus thread allocates nothing to run it, however
// often a drive that awaits a reset is tried again.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "drivebus/profile.hpp"
#include "master/block_setup.hpp"
#include "master/result.hpp"
#include "master/snapshot.hpp"
#include "rtu/pdu.hpp"

namespace drivebus::master {

enum class SetupState : std::uint8_t {
    Running,        // more requests to send
    Done,           // every selector holds and the read block returns what they select
    Failed,         // refused, read back otherwise, or the block returns something else
    AwaitingReset,  // selectors written that the drive applies only after a reset
};

class SetupPlan {
public:
    SetupPlan() = default;
    SetupPlan(rtu::SlaveAddress address, const Profile& profile, const std::vector<BlockSetup>& blocks);

    // Nothing to set up: no indirect block is used.
    [[nodiscard]] bool empty() const noexcept { return selectors_.empty(); }
    // Starts from the first step. Whether a reset is awaited, and the selection before it, stay.
    void restart() noexcept;
    // A sign that the drive was reset: it went silent and answers again (switched off and on),
    // or its fault was cleared. Selectors the read block can confirm still wait for that
    // confirmation; the others (the write block's) are taken as applied.
    void reset_seen() noexcept;
    // The next request; nullopt once the plan has finished (see state()).
    [[nodiscard]] std::optional<rtu::RequestAdu> next() const;
    // The result of the request next() gave.
    SetupState take(const Result& result);
    [[nodiscard]] SetupState state() const noexcept { return state_; }
    [[nodiscard]] const SetupNote& note() const noexcept { return note_; }
    [[nodiscard]] bool awaiting_reset() const noexcept { return awaiting_reset_; }

private:
    struct Selector {
        std::uint16_t reg = 0;
        std::uint16_t wanted = 0;
        bool after_reset = false;
        // The value it held before drivebusd's first write, while that write awaits a reset:
        // the selection still in effect.
        std::optional<std::uint16_t> before;
    };
    struct Slot {
        std::size_t position = 0;    // in the block, from 0
        std::uint16_t reg = 0;       // the register the selector chooses
        std::uint16_t selector = 0;  // its selector
    };
    enum class Phase : std::uint8_t { ReadSelector, WriteSelector, ReadBack, Block, Direct, BlockAgain, End };

    SetupState finish(SetupState state, SetupNote note = {});
    void after_selectors();
    [[nodiscard]] SetupState judge();
    // Where a value read through the block may lie: between the two block readings, with a
    // margin for a value that moves (or jitters) between reads. A bit-field register must agree
    // exactly when it holds still.
    [[nodiscard]] bool agrees(std::uint16_t reg, std::uint16_t value, std::size_t slot) const;
    [[nodiscard]] std::optional<std::uint16_t> previous_target(const Slot& slot) const;
    [[nodiscard]] const Selector* selector(std::uint16_t reg) const noexcept;
    [[nodiscard]] std::uint16_t direct_value(std::uint16_t reg) const noexcept;
    [[nodiscard]] std::uint16_t first_before() const noexcept;

    rtu::SlaveAddress address_ = 0;
    const Profile* profile_ = nullptr;
    std::vector<Selector> selectors_;
    // The read block's slots that select a register, in order; the quantity read through it.
    const IndirectBlock* read_block_ = nullptr;
    std::vector<Slot> slots_;
    std::uint16_t read_quantity_ = 0;
    // Registers read on their own to confirm the block: the slots' and those the selection
    // before would have given (while a reset is awaited); what they read, in the same order.
    std::vector<std::uint16_t> direct_;
    std::vector<std::uint16_t> read_;

    Phase phase_ = Phase::End;
    std::size_t index_ = 0;
    unsigned round_ = 0;
    SetupState state_ = SetupState::Running;
    SetupNote note_;
    std::vector<std::uint16_t> first_, second_;  // the two readings through the block
    bool awaiting_reset_ = false;
};

}  // namespace drivebus::master
