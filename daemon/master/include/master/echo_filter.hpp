// SPDX-License-Identifier: Apache-2.0
// Local echo on 2-wire adapters: the receiver hears the master's own transmission. The filter
// takes exactly the echoed request bytes off the received stream and checks them; a mismatch
// is a bus collision.
//
// In auto mode the first bytes heard after a request decide: if they are the whole request,
// the adapter echoes (and the filter stays on); if they differ before the end, there is no
// echo, and the bytes held so far are handed back to be framed as the reply. Requests whose
// reply is byte for byte the request (FC06) cannot tell and are not used to decide.
#pragma once

#include <cstdint>
#include <span>

#include "rtu/types.hpp"

namespace drivebus::master {

enum class EchoSetting : std::uint8_t { Off, On, Auto };

class EchoFilter {
public:
    enum class Status : std::uint8_t {
        Idle,      // nothing expected
        Pending,   // part of the echo still to come
        Matched,   // the whole echo arrived and matched
        Mismatch,  // it differed: a collision
        NoEcho,    // auto mode found there is no echo; see replay()
    };

    explicit EchoFilter(EchoSetting setting) noexcept : setting_(setting) {}

    // A request was written.
    void expect(const rtu::Adu& sent) noexcept;
    // Takes the echo off the front of `bytes`; returns how many bytes it consumed (the rest
    // belong to the reply). After NoEcho, replay() holds bytes taken from earlier reads that
    // must go to the framer before these.
    std::size_t consume(std::span<const std::uint8_t> bytes) noexcept;
    [[nodiscard]] Status status() const noexcept { return status_; }
    [[nodiscard]] std::span<const std::uint8_t> replay() const noexcept { return replay_.bytes(); }
    [[nodiscard]] EchoSetting setting() const noexcept { return setting_; }
    // Auto mode has made up its mind (On or Off).
    [[nodiscard]] bool decided() const noexcept { return setting_ != EchoSetting::Auto; }

private:
    EchoSetting setting_;
    rtu::Adu expected_;
    rtu::Adu replay_;
    std::size_t matched_ = 0;
    Status status_ = Status::Idle;
};

}  // namespace drivebus::master
