// Real-time set-up: which mappings are locked how, read from /proc/PID/maps text, and the
// locking itself in this process, with a large shared-memory file standing in for iceoryx's
// management segment; the service thread's priority under the bus threads'.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <fstream>
#include <sstream>
#include <vector>

#include "rt/memory.hpp"
#include "rt/realtime.hpp"
#include "sys/posix.hpp"

namespace drivebus::rt {
namespace {

const char* const kMaps =
    "55d0c0a00000-55d0c0a2c000 r--p 00000000 fd:01 1311  /usr/sbin/drivebusd\n"
    "55d0c0a2c000-55d0c0b00000 r-xp 0002c000 fd:01 1311  /usr/sbin/drivebusd\n"
    "55d0c2000000-55d0c2100000 rw-p 00000000 00:00 0     [heap]\n"
    "7f0000000000-7f0011000000 rw-s 00000000 00:1a 77    /dev/shm/iceoryx_mgmt\n"
    "7f0011000000-7f0011260000 rw-s 00000000 00:1a 78    /dev/shm/drivebus\n"
    "7f0012000000-7f0012001000 ---p 00000000 00:00 0 \n"
    "7f0012001000-7f0012801000 rw-p 00000000 00:00 0 \n"
    "7f0013000000-7f0013010000 r-xp 00000000 fd:01 99    /opt/a dir/lib with spaces.so (deleted)\n"
    "7ffc00000000-7ffc00021000 rw-p 00000000 00:00 0     [stack]\n"
    "7ffc00100000-7ffc00104000 r--p 00000000 00:00 0     [vvar]\n"
    "7ffc00104000-7ffc00106000 r-xp 00000000 00:00 0     [vdso]\n"
    "ffffffffff600000-ffffffffff601000 --xp 00000000 00:00 0 [vsyscall]\n"
    "not a mapping\n";

TEST(MapsTest, ReadsRangesAccessAndPaths) {
    const auto maps = parse_maps(kMaps);
    ASSERT_EQ(maps.size(), 12U) << "the line that is not a mapping is skipped";
    EXPECT_EQ(maps[0].begin, 0x55d0c0a00000U);
    EXPECT_EQ(maps[0].end, 0x55d0c0a2c000U);
    EXPECT_EQ(maps[0].path, "/usr/sbin/drivebusd");
    EXPECT_TRUE(maps[0].accessible);
    EXPECT_TRUE(maps[0].file());
    EXPECT_EQ(maps[3].path, "/dev/shm/iceoryx_mgmt");
    EXPECT_EQ(maps[3].bytes(), 0x11000000U);
    EXPECT_FALSE(maps[5].accessible);
    EXPECT_EQ(maps[5].path, "");
    EXPECT_FALSE(maps[6].file());
    EXPECT_EQ(maps[7].path, "/opt/a dir/lib with spaces.so (deleted)");
    EXPECT_EQ(maps[11].begin, 0xffffffffff600000U);
}

TEST(MapsTest, CodeAndPayloadWholeHeapAndStacksAsUsedManagementReservesAndKernelNot) {
    const auto maps = parse_maps(kMaps);
    const std::vector<std::string> left_out{"/dev/shm/iceoryx_mgmt"};
    const std::vector<Lock> expected{Lock::Whole,    Lock::Whole, Lock::Resident, Lock::No,
                                     Lock::Whole,    Lock::No,    Lock::Resident, Lock::Whole,
                                     Lock::Resident, Lock::No,    Lock::No,       Lock::No};
    ASSERT_EQ(maps.size(), expected.size());
    for (std::size_t i = 0; i < maps.size(); ++i) {
        EXPECT_EQ(how_to_lock(maps[i], left_out), expected[i]) << "line " << i << ": " << maps[i].path;
    }
    // Without the management segment left out, it would be read in and locked whole.
    EXPECT_EQ(how_to_lock(maps[3], {}), Lock::Whole);
}

TEST(StatusTest, ReadsKibFields) {
    const char* const status = "Name:\tdrivebusd\nVmLck:\t   12345 kB\nVmRSS:\t  76800 kB\nRssAnon:\t2048 kB\n";
    EXPECT_EQ(status_kib(status, "VmLck"), 12345U);
    EXPECT_EQ(status_kib(status, "VmRSS"), 76800U);
    EXPECT_EQ(status_kib(status, "RssAnon"), 2048U);
    EXPECT_EQ(status_kib(status, "VmHWM"), std::nullopt);
    EXPECT_EQ(status_kib(status, "Name"), std::nullopt) << "not a number";
    EXPECT_EQ(status_kib(status, "Vm"), std::nullopt) << "a prefix of a field is not the field";
}

std::string slurp(const char* path) {
    std::ifstream in(path);
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
}

std::size_t resident_pages(const void* data, std::size_t bytes);

// A shared-memory file mapped into this process, removed with it.
class ShmFile {
public:
    ShmFile(const std::string& name, std::size_t bytes) : path_("/dev/shm/" + name), bytes_(bytes) {
        const sys::UniqueFd fd(::open(path_.c_str(), O_RDWR | O_CREAT | O_TRUNC | O_CLOEXEC, 0600));
        if (!fd || ::ftruncate(fd.get(), static_cast<off_t>(bytes)) != 0) {
            throw std::runtime_error(path_ + ": " + std::strerror(errno));
        }
        data_ = ::mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_SHARED, fd.get(), 0);
        if (data_ == MAP_FAILED) {
            throw std::runtime_error(path_ + ": mmap: " + std::strerror(errno));
        }
    }
    ShmFile(const ShmFile&) = delete;
    ShmFile& operator=(const ShmFile&) = delete;
    ~ShmFile() {
        ::munmap(data_, bytes_);
        ::unlink(path_.c_str());
    }
    [[nodiscard]] const std::string& path() const { return path_; }
    // How many of its pages are resident (mincore).
    [[nodiscard]] std::size_t resident_pages() const;

private:
    std::string path_;
    std::size_t bytes_;
    void* data_ = nullptr;
};

std::size_t ShmFile::resident_pages() const {
    return rt::resident_pages(data_, bytes_);
}

std::size_t resident_pages(const void* data, std::size_t bytes) {
    const auto page = static_cast<std::size_t>(::sysconf(_SC_PAGESIZE));
    std::vector<unsigned char> in_core((bytes + page - 1) / page);
    if (::mincore(const_cast<void*>(data), bytes, in_core.data()) != 0) {  // NOLINT(cppcoreguidelines-pro-type-const-cast)
        throw std::runtime_error("mincore: " + std::string(std::strerror(errno)));
    }
    return static_cast<std::size_t>(std::ranges::count_if(in_core, [](unsigned char c) { return (c & 1) != 0; }));
}

// The real thing, in this test's own process: a 256 MiB segment left out stays unlocked and is
// not read in; a 1 MiB one (a payload segment) is read in and locked; of a 64 MiB anonymous
// mapping (a thread's stack, say) only the 1 MiB in use is locked; so is the program.
TEST(LockMemoryTest, LocksWhatTheProcessUsesAndLeavesTheSegmentOut) {
    if (::geteuid() != 0) {
        GTEST_SKIP() << "locking more than RLIMIT_MEMLOCK needs CAP_IPC_LOCK (root)";
    }
    constexpr std::size_t kMiB = std::size_t{1024} * 1024;
    const auto page = static_cast<std::size_t>(::sysconf(_SC_PAGESIZE));
    const std::string tag = std::to_string(::getpid());
    const ShmFile management("drivebus-test-mgmt-" + tag, 256 * kMiB);
    const ShmFile payload("drivebus-test-payload-" + tag, 1 * kMiB);
    ASSERT_EQ(payload.resident_pages(), 0U);
    void* const reserve = ::mmap(nullptr, 64 * kMiB, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    ASSERT_NE(reserve, MAP_FAILED);
    std::memset(reserve, 1, kMiB);
    prefault_stack();

    const std::vector<std::string> left_out{management.path()};
    const auto locked = lock_memory(left_out);
    ASSERT_TRUE(locked.has_value()) << locked.error();
    EXPECT_EQ(locked->left_out_kib, 256U * 1024U);
    EXPECT_EQ(management.resident_pages(), 0U) << "the segment left out was read in";
    EXPECT_EQ(payload.resident_pages(), kMiB / page);
    EXPECT_EQ(resident_pages(reserve, 64 * kMiB), kMiB / page) << "unused anonymous memory was made resident";
    const auto vm_lck = status_kib(slurp("/proc/self/status"), "VmLck");
    ASSERT_TRUE(vm_lck.has_value());
    EXPECT_LE(locked->locked_kib, *vm_lck) << "what is mapped since is locked too";
    EXPECT_GE(*vm_lck, 2048U) << "the payload segment and the anonymous memory in use are locked";
    EXPECT_LT(*vm_lck, 48U * 1024U) << "far more locked than this process uses";
    ::munmap(reserve, 64 * kMiB);
}

TEST(ServicePriorityTest, TenUnderTheBusThreadsAtLeastOneNothingUnderOne) {
    EXPECT_EQ(service_priority(50), 40);
    EXPECT_EQ(service_priority(99), 89);
    EXPECT_EQ(service_priority(11), 1);
    EXPECT_EQ(service_priority(5), 1);
    EXPECT_EQ(service_priority(2), 1);
    EXPECT_EQ(service_priority(1), std::nullopt);
}

}  // namespace
}  // namespace drivebus::rt
