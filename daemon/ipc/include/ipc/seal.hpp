// SPDX-License-Identifier: Apache-2.0
// Payload segments written only by their writer group.
//
// iceoryx 2.0 (MePooSegment) creates each payload segment, /dev/shm/<writer group>, with an ACL
// that grants its named writer group read and write, its named reader group read, and the
// file's owning group read and write as well. The owning group is RouDi's effective group,
// which every client must share (RouDi's socket and management segment are shared through
// it), so every client could open every segment for writing and overwrite what the others read.
// seal_segment() takes the owning group's entry down to what the segment grants that group by
// name, which leaves writing to the writer group (and the owner, drivebusd's user).
#pragma once

#include <expected>
#include <string>

#include "ipc/host.hpp"

namespace drivebus::ipc {

// "/dev/shm/drivebusd": where iceoryx keeps the segment written by `segment.writer_group`.
[[nodiscard]] std::string segment_path(const Segment& segment);

// Rewrites the segment file's ACL as above. Fails (one line naming the file) when the file is
// missing, or this process does not own it and so may not change its ACL.
[[nodiscard]] std::expected<void, std::string> seal_segment(const Segment& segment);

}  // namespace drivebus::ipc
