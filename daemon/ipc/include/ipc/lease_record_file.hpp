// SPDX-License-Identifier: Apache-2.0
// The bus's lease record on disk (ipc/lease_record.hpp says what it holds): STATE_DIR/BUS.leases,
// replaced whole (a temporary file renamed over it) so that a reader never sees half of one.
// /run is a tmpfs: no fsync. The ipc thread's only file I/O, and only when the record changes.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "config/config.hpp"
#include "ipc/lease_record.hpp"
#include "log/log.hpp"

namespace drivebus::ipc {

class LeaseRecordFile {
public:
    explicit LeaseRecordFile(const config::BusConfig& bus);

    // What the last drivebusd left; nullopt when there is no file (a first start). A file that
    // cannot be read is logged and taken as none.
    [[nodiscard]] std::optional<ReadLeaseRecord> read() const;
    // Writes `leases` when they differ from what was last written; a failure is logged (once a
    // minute) and tried again at the next change.
    void keep(const std::vector<RecordedLease>& leases);

    [[nodiscard]] const std::filesystem::path& path() const noexcept { return path_; }

private:
    std::string bus_;
    std::filesystem::path path_;
    std::optional<std::string> written_;
    log::RateLimited limiter_{std::chrono::seconds(60)};
};

}  // namespace drivebus::ipc
