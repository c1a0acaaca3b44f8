// SPDX-License-Identifier: Apache-2.0
// The ipc core's notes (ipc/lease_policy.hpp's Note: a level, a line, the drive it is about) are
// data; the ipc service writes them to the log here.
#pragma once

#include <optional>
#include <source_location>

#include "ipc/lease_policy.hpp"
#include "log/log.hpp"

namespace drivebus::ipc {

// Writes the line, if there is one, with DRIVE= when it names a drive.
inline void write_note(const std::optional<Note>& note, std::source_location where = std::source_location::current()) {
    if (note) {
        log::write(note->level, note->text, {.drive = note->drive}, where);
    }
}

}  // namespace drivebus::ipc
