// SPDX-License-Identifier: Apache-2.0
#include "master/setup_plan.hpp"

#include <algorithm>
#include <cstdlib>

namespace drivebus::master {
namespace {

constexpr unsigned kRounds = 3;  // confirmations tried before the block is said to differ

const rtu::ReadHoldingRegistersResponse* words(const Result& result) {
    if (result.outcome != Outcome::Ok || !result.response) {
        return nullptr;
    }
    return std::get_if<rtu::ReadHoldingRegistersResponse>(&*result.response);
}

std::optional<std::uint16_t> word(const Result& result) {
    const auto* w = words(result);
    if (w == nullptr || w->values.size() != 1) {
        return std::nullopt;
    }
    return w->values[0];
}

std::uint8_t exception_of(const Result& result) {
    const auto e = result.exception();
    return e ? static_cast<std::uint8_t>(*e) : 0;
}

}  // namespace

SetupPlan::SetupPlan(rtu::SlaveAddress address, const Profile& profile, const std::vector<BlockSetup>& blocks)
    : address_(address), profile_(&profile) {
    for (const BlockSetup& b : blocks) {
        const IndirectBlock* block = profile.block(b.function);
        if (block == nullptr) {
            continue;
        }
        std::size_t last = 0;
        for (std::size_t position = 0; position < b.slots.size(); ++position) {
            const BlockSlot& slot = b.slots[position];
            if (!slot.selector) {
                continue;
            }
            selectors_.push_back({*slot.selector, slot.value, block->selectors_after_reset, std::nullopt});
            if (b.function == 3 && slot.target) {
                slots_.push_back({position, *slot.target, *slot.selector});
                last = position + 1;
            }
        }
        if (b.function == 3 && !slots_.empty()) {
            read_block_ = block;
            read_quantity_ = static_cast<std::uint16_t>(std::max<std::size_t>(last, block->min_quantity));
        }
    }
    // At most each slot's register and the one its selection before chose.
    direct_.reserve(2 * slots_.size());
    read_.reserve(2 * slots_.size());
    first_.reserve(read_quantity_);
    second_.reserve(read_quantity_);
    restart();
}

const SetupPlan::Selector* SetupPlan::selector(std::uint16_t reg) const noexcept {
    const auto it = std::ranges::find(selectors_, reg, &Selector::reg);
    return it != selectors_.end() ? &*it : nullptr;
}

std::uint16_t SetupPlan::direct_value(std::uint16_t reg) const noexcept {
    const auto it = std::ranges::find(direct_, reg);
    const auto i = static_cast<std::size_t>(it - direct_.begin());
    return i < read_.size() ? read_[i] : 0;
}

std::uint16_t SetupPlan::first_before() const noexcept {
    const auto it = std::ranges::find_if(selectors_, [](const Selector& s) { return s.before.has_value(); });
    return it != selectors_.end() ? it->reg : 0;
}

void SetupPlan::restart() noexcept {
    phase_ = selectors_.empty() ? Phase::End : Phase::ReadSelector;
    state_ = selectors_.empty() ? SetupState::Done : SetupState::Running;
    index_ = 0;
    round_ = 0;
    first_.clear();
    second_.clear();
    read_.clear();
}

void SetupPlan::reset_seen() noexcept {
    const bool block_can_tell = std::ranges::any_of(slots_, [&](const Slot& slot) {
        const Selector* s = selector(slot.selector);
        return s != nullptr && s->before.has_value();
    });
    if (!block_can_tell) {
        awaiting_reset_ = false;
        for (Selector& s : selectors_) {
            s.before.reset();
        }
    }
}

std::optional<rtu::RequestAdu> SetupPlan::next() const {
    switch (phase_) {
    case Phase::ReadSelector:
    case Phase::ReadBack: return rtu::RequestAdu{address_, rtu::ReadHoldingRegisters{selectors_[index_].reg, 1}};
    case Phase::WriteSelector:
        return rtu::RequestAdu{address_, rtu::WriteSingleRegister{selectors_[index_].reg, selectors_[index_].wanted}};
    case Phase::Block:
    case Phase::BlockAgain:
        return rtu::RequestAdu{address_, rtu::ReadHoldingRegisters{read_block_->address, read_quantity_}};
    case Phase::Direct: return rtu::RequestAdu{address_, rtu::ReadHoldingRegisters{direct_[index_], 1}};
    case Phase::End: break;
    }
    return std::nullopt;
}

SetupState SetupPlan::finish(SetupState state, SetupNote note) {
    phase_ = Phase::End;
    state_ = state;
    note_ = note;
    return state_;
}

SetupState SetupPlan::take(const Result& result) {
    const auto refused = [&](std::uint16_t reg, std::uint16_t wanted) {
        return finish(SetupState::Failed, {SetupNote::Kind::Refused, reg, wanted, 0, 0, 0, exception_of(result)});
    };
    switch (phase_) {
    case Phase::ReadSelector:
    case Phase::ReadBack: {
        Selector& sel = selectors_[index_];
        const auto value = word(result);
        if (!value) {
            return refused(sel.reg, sel.wanted);
        }
        if (*value != sel.wanted) {
            if (phase_ == Phase::ReadBack) {
                return finish(SetupState::Failed, {SetupNote::Kind::ReadBack, sel.reg, sel.wanted, *value});
            }
            // The selection in effect until the drive is reset is the one before drivebusd's
            // first write: a later write does not change it.
            if (sel.after_reset && !sel.before) {
                sel.before = *value;
            }
            phase_ = Phase::WriteSelector;
            return state_;
        }
        if (phase_ == Phase::ReadBack && sel.after_reset) {
            awaiting_reset_ = true;
        }
        if (++index_ < selectors_.size()) {
            phase_ = Phase::ReadSelector;
            return state_;
        }
        after_selectors();
        return state_;
    }
    case Phase::WriteSelector:
        if (result.outcome != Outcome::Ok) {
            return refused(selectors_[index_].reg, selectors_[index_].wanted);
        }
        phase_ = Phase::ReadBack;
        return state_;
    case Phase::Block:
    case Phase::BlockAgain: {
        const auto* w = words(result);
        if (w == nullptr || w->values.size() != read_quantity_) {
            return refused(read_block_->address, read_quantity_);
        }
        if (phase_ == Phase::Block) {
            first_.assign(w->values.words().begin(), w->values.words().end());
            phase_ = Phase::Direct;
            index_ = 0;
            return state_;
        }
        second_.assign(w->values.words().begin(), w->values.words().end());
        return judge();
    }
    case Phase::Direct: {
        const auto value = word(result);
        if (!value) {
            return refused(direct_[index_], 0);
        }
        read_.push_back(*value);
        if (++index_ >= direct_.size()) {
            phase_ = Phase::BlockAgain;
        }
        return state_;
    }
    case Phase::End: break;
    }
    return state_;
}

void SetupPlan::after_selectors() {
    if (read_block_ == nullptr) {
        if (awaiting_reset_) {
            finish(SetupState::AwaitingReset, {SetupNote::Kind::NotApplied, first_before()});
        } else {
            finish(SetupState::Done);
        }
        return;
    }
    direct_.clear();
    const auto add = [&](std::uint16_t reg) {
        if (std::ranges::find(direct_, reg) == direct_.end()) {
            direct_.push_back(reg);
        }
    };
    for (const Slot& slot : slots_) {
        add(slot.reg);
        if (const auto before = previous_target(slot)) {
            add(*before);
        }
    }
    read_.clear();
    phase_ = Phase::Block;
    round_ = 0;
}

std::optional<std::uint16_t> SetupPlan::previous_target(const Slot& slot) const {
    const Selector* s = selector(slot.selector);
    if (s == nullptr || !s->before) {
        return std::nullopt;
    }
    const auto choice = read_block_->choices.find(*s->before);
    if (choice == read_block_->choices.end()) {
        return std::nullopt;  // it selected nothing: the slot read 0
    }
    const RegisterInfo* r = profile_->find(std::string_view(choice->second));
    return r != nullptr ? r->address : std::nullopt;
}

bool SetupPlan::agrees(std::uint16_t reg, std::uint16_t value, std::size_t position) const {
    const RegisterInfo* info = profile_->find(reg);
    const bool is_signed = info != nullptr && info->is_signed;
    const auto as_int = [&](std::uint16_t raw) {
        return is_signed ? static_cast<std::int32_t>(static_cast<std::int16_t>(raw)) : static_cast<std::int32_t>(raw);
    };
    const std::int32_t a = as_int(first_[position]);
    const std::int32_t b = as_int(second_[position]);
    const std::int32_t lo = std::min(a, b);
    const std::int32_t hi = std::max(a, b);
    std::int32_t margin = hi - lo;
    if (info == nullptr || info->bits.empty()) {
        margin = std::max({margin, std::max(std::abs(lo), std::abs(hi)) / 50, 1});
    }
    const std::int32_t v = as_int(value);
    return v >= lo - margin && v <= hi + margin;
}

SetupState SetupPlan::judge() {
    for (const Slot& slot : slots_) {
        const std::uint16_t direct = direct_value(slot.reg);
        if (agrees(slot.reg, direct, slot.position)) {
            continue;
        }
        if (++round_ < kRounds) {
            phase_ = Phase::Block;  // a value that moved too fast: read again
            read_.clear();
            return state_;
        }
        const SetupNote note{SetupNote::Kind::BlockDiffers,
                             slot.reg,
                             direct,
                             first_[slot.position],
                             read_block_->address,
                             static_cast<std::uint8_t>(slot.position + 1)};
        return finish(awaiting_reset_ ? SetupState::AwaitingReset : SetupState::Failed, note);
    }
    if (!awaiting_reset_) {
        return finish(SetupState::Done);
    }
    // Every slot agrees with the new selection; it proves the reset only where the selection
    // before would have read otherwise.
    bool told = false;
    bool block_waits = false;
    for (const Slot& slot : slots_) {
        const Selector* s = selector(slot.selector);
        if (s == nullptr || !s->before) {
            continue;
        }
        block_waits = true;
        const auto before = previous_target(slot);
        const std::uint16_t old_value = before ? direct_value(*before) : 0;
        told = told || !agrees(slot.reg, old_value, slot.position);
    }
    if (!block_waits) {
        // Only selectors the block cannot show were written (the write block's).
        return finish(SetupState::AwaitingReset, {SetupNote::Kind::NotApplied, first_before()});
    }
    if (!told) {
        return finish(SetupState::AwaitingReset, {SetupNote::Kind::CannotTell, 0, 0, 0, read_block_->address});
    }
    awaiting_reset_ = false;
    for (Selector& sel : selectors_) {
        sel.before.reset();
    }
    return finish(SetupState::Done);
}

}  // namespace drivebus::master
