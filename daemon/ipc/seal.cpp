// SPDX-License-Identifier: Apache-2.0
#include "ipc/seal.hpp"

#include <fcntl.h>
#include <grp.h>
#include <sys/acl.h>
#include <sys/stat.h>

#include <cerrno>
#include <memory>
#include <optional>
#include <type_traits>

#include "sys/posix.hpp"

namespace drivebus::ipc {
namespace {

struct AclFree {
    void operator()(void* acl) const noexcept { ::acl_free(acl); }
};
using Acl = std::unique_ptr<std::remove_pointer_t<acl_t>, AclFree>;

std::optional<gid_t> gid_of(const std::string& group) {
    const auto* entry = ::getgrnam(group.c_str());
    return entry != nullptr ? std::optional<gid_t>(entry->gr_gid) : std::nullopt;
}

// The owning group's entry gets what the segment grants that group by name: read and write
// when it is the writer group, read when it is the reader group, nothing otherwise.
bool restrict_owning_group(acl_t acl, gid_t owner, std::optional<gid_t> reader, std::optional<gid_t> writer) {
    acl_entry_t entry = nullptr;
    for (int which = ACL_FIRST_ENTRY; ::acl_get_entry(acl, which, &entry) == 1; which = ACL_NEXT_ENTRY) {
        acl_tag_t tag = ACL_UNDEFINED_TAG;
        if (::acl_get_tag_type(entry, &tag) != 0 || tag != ACL_GROUP_OBJ) {
            continue;
        }
        acl_permset_t perms = nullptr;
        if (::acl_get_permset(entry, &perms) != 0 || ::acl_clear_perms(perms) != 0) {
            return false;
        }
        if (owner == writer || owner == reader) {
            ::acl_add_perm(perms, ACL_READ);
        }
        if (owner == writer) {
            ::acl_add_perm(perms, ACL_WRITE);
        }
        return ::acl_set_permset(entry, perms) == 0;
    }
    return false;
}

}  // namespace

std::string segment_path(const Segment& segment) {
    return "/dev/shm/" + segment.writer_group;
}

std::expected<void, std::string> seal_segment(const Segment& segment) {
    const auto path = segment_path(segment);
    const auto failed = [&](const sys::SysError& e) { return std::unexpected(path + ": " + e.message()); };
    const auto fd = sys::posix_call("open", [&] { return ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW); });
    if (!fd) {
        return failed(fd.error());
    }
    const sys::UniqueFd file(*fd);
    struct stat st{};
    if (const auto rc = sys::posix_call("fstat", [&] { return ::fstat(file.get(), &st); }); !rc) {
        return failed(rc.error());
    }
    Acl acl(::acl_get_fd(file.get()));
    if (!acl) {
        return failed({"acl_get_fd", errno});
    }
    if (!restrict_owning_group(acl.get(), st.st_gid, gid_of(segment.reader_group), gid_of(segment.writer_group))) {
        return failed({"acl_set_permset", errno});
    }
    // The mask bounds every group entry: recomputed, it keeps what the named groups need.
    acl_t raw = acl.release();
    const int calc = ::acl_calc_mask(&raw);
    acl.reset(raw);
    if (calc != 0) {
        return failed({"acl_calc_mask", errno});
    }
    if (const auto rc = sys::posix_call("acl_set_fd", [&] { return ::acl_set_fd(file.get(), acl.get()); }); !rc) {
        return failed(rc.error());
    }
    return {};
}

}  // namespace drivebus::ipc
