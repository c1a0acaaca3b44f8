// SPDX-License-Identifier: Apache-2.0
// What drivebusd keeps of a bus's control leases between two of its runs: the drives whose
// lease is held (or whose fallback is on its way), and those whose fallback the drive has not
// confirmed (the write failed: timed out, refused), so that a drivebusd that starts after one
// that was killed, crashed or stopped on a line that failed applies their fallbacks before
// anything else reaches them. One small text file per bus (daemon/ipc/lease_record_file.hpp
// writes it, before the first command of a lease is sent); never the token.
//
//   drivebus-leases 1
//   lease pump 1 stop pump-control[1234]
//   unconfirmed fan 2 freewheel fan-control[99]
//
// Fields: the drive's name, its address and fallback as they were, and the holder's name (the
// rest of the line, for the log). Pure: text in, text out.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "config/config.hpp"

namespace drivebus::ipc {

struct RecordedLease {
    std::string drive;
    std::optional<int> address;                     // unreadable: nullopt
    std::optional<config::LeaseFallback> fallback;  // unreadable: nullopt
    std::string holder;
    bool unconfirmed = false;  // not held: its fallback was written and the drive did not confirm it

    bool operator==(const RecordedLease&) const = default;
};

// The file's text for `leases` (a header line alone for none).
[[nodiscard]] std::string format_lease_record(const std::vector<RecordedLease>& leases);

struct ReadLeaseRecord {
    std::vector<RecordedLease> leases;
    std::vector<std::string> problems;  // one line each: what could not be read, and where
};

// Reads what it can. Every line that names a drive counts, however damaged the rest of it or
// the header: a lease recorded as held is the one thing not to lose (its fallback is taken
// from the configuration now, not from the file).
[[nodiscard]] ReadLeaseRecord parse_lease_record(std::string_view text);

}  // namespace drivebus::ipc
