// SPDX-License-Identifier: Apache-2.0
#include "master/echo_filter.hpp"

namespace drivebus::master {
namespace {
constexpr std::uint8_t kWriteSingleRegister = 0x06;
}

void EchoFilter::expect(const rtu::Adu& sent) noexcept {
    replay_.clear();
    matched_ = 0;
    const bool undecidable = setting_ == EchoSetting::Auto && sent.size() > 1 && sent[1] == kWriteSingleRegister;
    if (setting_ == EchoSetting::Off || undecidable) {
        status_ = Status::Idle;
        return;
    }
    expected_ = sent;
    status_ = Status::Pending;
}

std::size_t EchoFilter::consume(std::span<const std::uint8_t> bytes) noexcept {
    if (status_ != Status::Pending) {
        return 0;
    }
    const std::size_t before = matched_;
    std::size_t used = 0;
    while (used < bytes.size() && matched_ < expected_.size()) {
        if (bytes[used] != expected_[matched_]) {
            if (setting_ == EchoSetting::Auto) {
                // Not an echo but the reply: give back what was held from earlier reads; the
                // bytes of this read are not consumed.
                setting_ = EchoSetting::Off;
                status_ = Status::NoEcho;
                replay_.clear();
                (void)replay_.append(expected_.bytes().first(before));
                return 0;
            }
            status_ = Status::Mismatch;
            return used + 1;  // the differing byte is part of the garbled echo
        }
        ++matched_;
        ++used;
    }
    if (matched_ == expected_.size()) {
        status_ = Status::Matched;
        if (setting_ == EchoSetting::Auto) {
            setting_ = EchoSetting::On;
        }
    }
    return used;
}

}  // namespace drivebus::master
