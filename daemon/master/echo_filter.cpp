#include "master/echo_filter.hpp"

namespace drivebus::master {

void EchoFilter::expect(const rtu::Adu& sent) noexcept {
    if (setting_ == EchoSetting::Off) {
        status_ = Status::Idle;
        return;
    }
    expected_ = sent;
    matched_ = 0;
    status_ = Status::Pending;
}

std::size_t EchoFilter::consume(std::span<const std::uint8_t> bytes) noexcept {
    if (status_ != Status::Pending) {
        return 0;
    }
    std::size_t used = 0;
    while (used < bytes.size() && matched_ < expected_.size()) {
        if (bytes[used] != expected_[matched_]) {
            if (setting_ == EchoSetting::Auto && matched_ == 0) {
                // The first byte heard is not our first byte: this adapter does not echo.
                setting_ = EchoSetting::Off;
                status_ = Status::Idle;
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

void EchoFilter::no_echo() noexcept {
    if (status_ == Status::Pending && matched_ == 0 && setting_ == EchoSetting::Auto) {
        setting_ = EchoSetting::Off;
        status_ = Status::Idle;
    }
}

}  // namespace drivebus::master
