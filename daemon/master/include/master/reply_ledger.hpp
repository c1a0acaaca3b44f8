// SPDX-License-Identifier: Apache-2.0
// Which reply can be whose: the requests a slave has not yet been seen to answer.
//
// Modbus RTU has no transaction id, and a slave that answers after the master has given up on
// a request (a stalled drive, a kernel that held its reply back) answers it in the next
// request's wait. Where both requests have replies of one shape (the ATV21 reads one register
// per FC03), the bytes cannot tell them apart. What can: a slave answers its requests one at a
// time and in order. So the ledger keeps each attempt whose reply has not been seen, and a
// frame is taken for the reply to the oldest attempt it could answer; everything older than
// that is answered or was dropped. A reply that could be an earlier transaction's is never
// the current one's. Before a request whose reply could be confused with one still owed, a
// *sync probe* goes out: a request whose reply cannot be confused with any owed one (the
// ATV21's FC43 device identification, or an FC03 read of another length). Its reply proves
// that the slave has answered or dropped everything before it.
//
// Owed attempts are forgotten after `forget` (a reply later than that is beyond what the
// master can guard against) and when more than kCapacity are owed (the oldest go first).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "rtu/limits.hpp"
#include "rtu/pdu.hpp"
#include "rtu/timing.hpp"

namespace drivebus {
struct Profile;
}

namespace drivebus::master {

// Whether a reply to `a` could be taken for a reply to `b` (both to one slave): the same
// function and, for a read, the same length; for a write, the same echo.
[[nodiscard]] bool confusable(const rtu::Request& a, const rtu::Request& b) noexcept;

// Requests a slave of this profile answers whatever state it is in, to prove it in step: FC43
// with each basic read code where it identifies itself, and FC03 reads of 1 to 3 of its readable
// registers in a row. Only requests that `limits` allows.
[[nodiscard]] std::vector<rtu::Request> sync_probes(const Profile& profile, const rtu::FunctionLimits& limits);

class ReplyLedger {
public:
    static constexpr std::size_t kCapacity = 16;

    struct Owed {
        std::uint64_t transaction = 0;  // the engine's serial of the transaction that sent it
        rtu::Request request;
        rtu::Instant sent{};
    };
    enum class Match : std::uint8_t {
        None,     // the frame answers nothing owed
        Current,  // the oldest attempt it can answer is the transaction's own
        Earlier,  // it can answer an earlier transaction's attempt: a late reply to that
    };

    // An attempt of `transaction` to `address` was written.
    void sent(rtu::SlaveAddress address, std::uint64_t transaction, const rtu::Request& request, rtu::Instant now);
    // A complete frame from `address` while `transaction` is current (0: none). The attempt it
    // answers and every older one are settled.
    Match received(rtu::SlaveAddress address, std::span<const std::uint8_t> adu, std::uint64_t transaction);
    // Drops what is older than `forget` at `now`.
    void forget(rtu::SlaveAddress address, rtu::Instant now, rtu::Duration forget);
    // Drops everything owed by `address`.
    void clear(rtu::SlaveAddress address) noexcept { slaves_[address].clear(); }
    // Whether a reply to `request` could still be taken for one owed by `address`.
    [[nodiscard]] bool in_doubt(rtu::SlaveAddress address, const rtu::Request& request) const noexcept;
    // The first of `probes` whose reply can be confused neither with an owed one nor with
    // `next`'s; if every one of them can be an owed one's, the first that cannot be `next`'s.
    [[nodiscard]] std::optional<rtu::Request> choose_probe(rtu::SlaveAddress address,
                                                           std::span<const rtu::Request> probes,
                                                           const rtu::Request& next) const;
    [[nodiscard]] std::size_t owed(rtu::SlaveAddress address) const noexcept { return slaves_[address].size(); }

private:
    std::array<std::vector<Owed>, 256> slaves_;
};

}  // namespace drivebus::master
