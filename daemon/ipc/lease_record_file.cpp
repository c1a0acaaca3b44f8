// SPDX-License-Identifier: Apache-2.0
#include "ipc/lease_record_file.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>

#include "sys/posix.hpp"

namespace drivebus::ipc {

namespace fs = std::filesystem;

LeaseRecordFile::LeaseRecordFile(const config::BusConfig& bus)
    : bus_(bus.name), path_(bus.state_dir / (bus.name + ".leases")) {}

std::optional<ReadLeaseRecord> LeaseRecordFile::read() const {
    std::error_code ec;
    if (!fs::exists(path_, ec)) {
        return std::nullopt;
    }
    std::ifstream in(path_, std::ios::binary);
    if (!in) {
        log::error("bus " + bus_ + ": lease record " + path_.string() + ": " + std::strerror(errno) +
                       "; the leases held when drivebusd last stopped are unknown",
                   {.bus = bus_});
        return std::nullopt;
    }
    std::ostringstream text;
    text << in.rdbuf();
    return parse_lease_record(text.str());
}

void LeaseRecordFile::keep(const std::vector<RecordedLease>& leases) {
    auto text = format_lease_record(leases);
    if (written_ == text) {
        return;
    }
    const auto fail = [&](const std::string& what, int error) {
        limiter_.write(log::Level::Warning, "write",
                       "bus " + bus_ + ": lease record " + path_.string() + ": " + what + ": " + std::strerror(error) +
                           "; a drivebusd killed now would not apply the held leases' fallbacks when it starts again",
                       {.bus = bus_});
    };
    std::error_code ec;
    fs::create_directories(path_.parent_path(), ec);
    const fs::path temporary = path_.string() + ".new";
    auto opened = sys::posix_call(
        "open", [&] { return ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC | O_NOFOLLOW, 0640); });
    if (!opened) {
        fail("cannot create " + temporary.filename().string(), opened.error().error);
        return;
    }
    const sys::UniqueFd fd(*opened);
    std::size_t done = 0;
    while (done < text.size()) {
        auto n = sys::posix_call("write", [&] { return ::write(fd.get(), text.data() + done, text.size() - done); });
        if (!n) {
            fail("cannot write", n.error().error);
            return;
        }
        done += static_cast<std::size_t>(*n);
    }
    // Durable before it replaces the record: a power cut after the rename finds the new text
    // (the caller sends the command that took a lease only once this returns).
    if (auto synced = sys::posix_call("fsync", [&] { return ::fsync(fd.get()); }); !synced) {
        fail("cannot sync " + temporary.filename().string(), synced.error().error);
        return;
    }
    if (auto renamed = sys::posix_call("rename", [&] { return ::rename(temporary.c_str(), path_.c_str()); });
        !renamed) {
        fail("cannot rename " + temporary.filename().string() + " over it", renamed.error().error);
        return;
    }
    // The rename itself, in the directory.
    if (auto dir = sys::posix_call(
            "open", [&] { return ::open(path_.parent_path().c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC); });
        dir) {
        const sys::UniqueFd dir_fd(*dir);
        if (auto synced = sys::posix_call("fsync", [&] { return ::fsync(dir_fd.get()); }); !synced) {
            fail("cannot sync its directory", synced.error().error);
            return;
        }
    }
    limiter_.reset("write");
    written_ = std::move(text);
}

}  // namespace drivebus::ipc
