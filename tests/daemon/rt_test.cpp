// SPDX-License-Identifier: Apache-2.0
// Real-time set-up: which mappings are locked how, read from /proc/PID/maps text, and the
// locking itself in this process, with a large shared-memory file standing in for iceoryx's
// management segment; the service thread's priority under the bus threads'.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

#include "rt/kernel_facts.hpp"
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
    const std::vector<Lock> expected{Lock::Whole,    Lock::Whole, Lock::Resident, Lock::No, Lock::Whole, Lock::No,
                                     Lock::Resident, Lock::Whole, Lock::Resident, Lock::No, Lock::No,    Lock::No};
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
    if (::mincore(const_cast<void*>(data), bytes, in_core.data()) !=
        0) {  // NOLINT(cppcoreguidelines-pro-type-const-cast)
        throw std::runtime_error("mincore: " + std::string(std::strerror(errno)));
    }
    return static_cast<std::size_t>(std::ranges::count_if(in_core, [](unsigned char c) { return (c & 1) != 0; }));
}

// The locked KiB of the mappings within [begin, begin + bytes), from /proc/self/smaps.
std::size_t locked_kib_within(const void* begin, std::size_t bytes) {
    const auto lo = reinterpret_cast<std::uintptr_t>(begin);
    const auto hi = lo + bytes;
    std::istringstream smaps(slurp("/proc/self/smaps"));
    std::string line;
    bool inside = false;
    std::size_t kib = 0;
    while (std::getline(smaps, line)) {
        const auto maps = parse_maps(line);
        if (!maps.empty() && line.find(':') > line.find(' ')) {  // a mapping's own line, not "Name: value"
            inside = maps[0].begin >= lo && maps[0].end <= hi;
        } else if (inside && line.starts_with("Locked:")) {
            kib += status_kib(line, "Locked").value_or(0);
        }
    }
    return kib;
}

// The real thing, in this test's own process: a 256 MiB segment left out stays unlocked and is
// not read in; a 1 MiB one (a payload segment) is read in and locked; of a 2 GiB anonymous
// mapping (a thread's stack, say) only the 1 MiB in use is locked, where it straddles two of
// the windows lock_memory() looks through; so is the program.
TEST(LockMemoryTest, LocksWhatTheProcessUsesAndLeavesTheSegmentOut) {
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
    // A sanitizer reserves terabytes of shadow memory in the process: what lock_memory() looks
    // through is then the sanitizer's, not the daemon's. The g++ stage runs this test.
    GTEST_SKIP() << "memory locking is measured without a sanitizer";
#endif
    if (::geteuid() != 0) {
        GTEST_SKIP() << "locking more than RLIMIT_MEMLOCK needs CAP_IPC_LOCK (root)";
    }
    constexpr std::size_t kMiB = std::size_t{1024} * 1024;
    const auto page = static_cast<std::size_t>(::sysconf(_SC_PAGESIZE));
    const std::string tag = std::to_string(::getpid());
    const ShmFile management("drivebus-test-mgmt-" + tag, 256 * kMiB);
    const ShmFile payload("drivebus-test-payload-" + tag, 1 * kMiB);
    ASSERT_EQ(payload.resident_pages(), 0U);
    constexpr std::size_t kReserve = 2048 * kMiB;
    void* const reserve =
        ::mmap(nullptr, kReserve, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS | MAP_NORESERVE, -1, 0);
    ASSERT_NE(reserve, MAP_FAILED);
    std::memset(static_cast<char*>(reserve) + 1024 * kMiB - kMiB / 2, 1, kMiB);
    prefault_stack();

    const std::vector<std::string> left_out{management.path()};
    const auto locked = lock_memory(left_out);
    ASSERT_TRUE(locked.has_value()) << locked.error();
    EXPECT_EQ(locked->left_out_kib, 256U * 1024U);
    EXPECT_EQ(management.resident_pages(), 0U) << "the segment left out was read in";
    EXPECT_EQ(payload.resident_pages(), kMiB / page);
    EXPECT_EQ(resident_pages(reserve, kReserve), kMiB / page) << "unused anonymous memory was made resident";
    EXPECT_EQ(locked_kib_within(reserve, kReserve), 1024U) << "the anonymous memory in use is not all locked";
    const auto vm_lck = status_kib(slurp("/proc/self/status"), "VmLck");
    ASSERT_TRUE(vm_lck.has_value());
    EXPECT_LE(locked->locked_kib, *vm_lck) << "what is mapped since is locked too";
    EXPECT_GE(*vm_lck, 2048U) << "the payload segment and the anonymous memory in use are locked";
    EXPECT_LT(*vm_lck, 128U * 1024U) << "far more locked than this process uses";
    ::munmap(reserve, kReserve);
}

TEST(ServicePriorityTest, TenUnderTheBusThreadsAtLeastOneNothingUnderOne) {
    EXPECT_EQ(service_priority(50), 40);
    EXPECT_EQ(service_priority(99), 89);
    EXPECT_EQ(service_priority(11), 1);
    EXPECT_EQ(service_priority(5), 1);
    EXPECT_EQ(service_priority(2), 1);
    EXPECT_EQ(service_priority(1), std::nullopt);
}

TEST(KernelFactsTest, CpumasksAsSysfsWritesThem) {
    EXPECT_EQ(parse_cpumask("f"), (std::vector<int>{0, 1, 2, 3}));
    EXPECT_EQ(parse_cpumask("00000000,00000005"), (std::vector<int>{0, 2}));
    EXPECT_EQ(parse_cpumask("1,00000000"), (std::vector<int>{32}));
    EXPECT_EQ(parse_cpumask("A"), (std::vector<int>{1, 3}));
    EXPECT_EQ(parse_cpumask(""), std::nullopt);
    EXPECT_EQ(parse_cpumask("0-3"), std::nullopt) << "a CPU list is not a mask";
}

std::vector<std::string> texts(const std::vector<Finding>& findings, bool against) {
    std::vector<std::string> out;
    for (const auto& f : findings) {
        if (f.against_framing == against) {
            out.push_back(f.text);
        }
    }
    return out;
}

TEST(KernelFactsTest, AStockKernelAndAWorkerKeptOffTheBusCpusWorkAgainstFraming) {
    const KernelFacts kernel{"#1 SMP PREEMPT_DYNAMIC Debian 6.1.0", std::nullopt, "c", {1}};
    const auto findings = judge(kernel, PortFacts{"ttyS1", {}, {}});
    ASSERT_EQ(findings.size(), 2U) << "nothing about a port attribute it does not have";
    EXPECT_EQ(texts(findings, true),
              (std::vector<std::string>{
                  "kernel: not PREEMPT_RT (#1 SMP PREEMPT_DYNAMIC Debian 6.1.0): under load, received bytes can reach "
                  "drivebusd milliseconds after they were on the wire",
                  "tty worker (unbound workqueue, normal priority) on CPUs 2-3, none of the bus threads' CPUs 1: kept "
                  "off them, it waits behind the load on the others"}));
}

TEST(KernelFactsTest, PreemptRtAndAWorkerOnTheBusCpusAreInfo) {
    for (const auto& kernel : {KernelFacts{"#1 SMP PREEMPT_RT Debian 6.1.0-rt", std::nullopt, "c", {2, 3}},
                               KernelFacts{"#1 SMP", "1", "c", {3, 2}}}) {
        const auto findings = judge(kernel, PortFacts{"ttyS1", {}, {}});
        ASSERT_EQ(findings.size(), 2U);
        EXPECT_TRUE(texts(findings, true).empty()) << texts(findings, true).front();
        EXPECT_EQ(findings[0].text, "kernel: PREEMPT_RT (" + kernel.version +
                                        "): interrupt handlers run in threads that can be given real-time priority");
        EXPECT_EQ(findings[1].text,
                  "tty worker (unbound workqueue, normal priority) on CPUs 2-3, all of them the bus threads' CPUs 2-3");
    }
}

TEST(KernelFactsTest, WorkerCpusAgainstAnyAndSomeBusCpus) {
    KernelFacts kernel{"#1 SMP PREEMPT_RT", std::nullopt, "f", {}};
    EXPECT_EQ(judge(kernel, {})[1].text,
              "tty worker (unbound workqueue, normal priority) on CPUs 0-3; the bus threads "
              "on any CPU: it competes with every other task");
    kernel.bus_cpus = {3, 5};
    EXPECT_EQ(judge(kernel, {})[1].text,
              "tty worker (unbound workqueue, normal priority) on CPUs 0-3, of them the bus threads' 3");
    EXPECT_FALSE(judge(kernel, {})[1].against_framing);
    kernel.unbound_cpumask.reset();
    EXPECT_EQ(judge(kernel, {})[1].text, "tty worker (unbound workqueue): its cpumask is not readable");
}

TEST(KernelFactsTest, PortAttributesAgainstFramingOnlyWhenDrivebusdCannotSetThem) {
    const KernelFacts kernel{"#1 SMP PREEMPT_RT", std::nullopt, "1", {0}};
    auto port = PortFacts{"ttyUSB0", Attribute{"16", true}, std::nullopt};
    auto findings = judge(kernel, port);
    ASSERT_EQ(findings.size(), 3U);
    EXPECT_EQ(findings[2].text, "ttyUSB0: latency_timer 16 ms; drivebusd sets 1 ms when it opens the port");
    EXPECT_FALSE(findings[2].against_framing);
    port.latency_timer = Attribute{"16", false};
    findings = judge(kernel, port);
    EXPECT_EQ(findings[2].text,
              "ttyUSB0: latency_timer 16 ms, not writable: the adapter holds received bytes back up "
              "to 16 ms (a udev rule can set 1)");
    EXPECT_TRUE(findings[2].against_framing);
    port.latency_timer = Attribute{"1", false};
    EXPECT_EQ(judge(kernel, port)[2].text, "ttyUSB0: latency_timer 1 ms");
    EXPECT_FALSE(judge(kernel, port)[2].against_framing);

    port = PortFacts{"ttyS1", std::nullopt, Attribute{"8", false}};
    findings = judge(kernel, port);
    ASSERT_EQ(findings.size(), 3U);
    EXPECT_EQ(findings[2].text,
              "ttyS1: rx_trig_bytes 8, not writable: received bytes wait in the FIFO for 8 of them "
              "or its time-out (about 4 characters)");
    EXPECT_TRUE(findings[2].against_framing);
    port.rx_trig_bytes = Attribute{"8", true};
    EXPECT_EQ(judge(kernel, port)[2].text,
              "ttyS1: rx_trig_bytes 8; drivebusd sets the lowest level when it opens the port");
    port.rx_trig_bytes = Attribute{"1", false};
    EXPECT_EQ(judge(kernel, port)[2].text, "ttyS1: rx_trig_bytes 1");
}

// The reading side, on a made-up /sys.
TEST(KernelFactsTest, ReadsSysfs) {
    const auto root = std::filesystem::temp_directory_path() / ("drivebus-sysfs-" + std::to_string(::getpid()));
    std::filesystem::create_directories(root / "kernel");
    std::filesystem::create_directories(root / "devices" / "virtual" / "workqueue");
    std::filesystem::create_directories(root / "class" / "tty" / "ttyUSB0" / "device");
    std::filesystem::create_directories(root / "class" / "tty" / "ttyS1");
    std::ofstream(root / "kernel" / "realtime") << "1\n";
    std::ofstream(root / "devices" / "virtual" / "workqueue" / "cpumask") << "00000000,00000003\n";
    std::ofstream(root / "class" / "tty" / "ttyUSB0" / "device" / "latency_timer") << "16\n";
    std::ofstream(root / "class" / "tty" / "ttyS1" / "rx_trig_bytes") << "14\n";
    const auto kernel = read_kernel_facts({1}, root);
    EXPECT_FALSE(kernel.version.empty());
    EXPECT_EQ(kernel.realtime, "1");
    EXPECT_EQ(kernel.unbound_cpumask, "00000000,00000003");
    EXPECT_EQ(kernel.bus_cpus, std::vector<int>{1});
    const auto usb = read_port_facts("ttyUSB0", root / "class" / "tty");
    ASSERT_TRUE(usb.latency_timer.has_value());
    EXPECT_EQ(usb.latency_timer->value, "16");
    EXPECT_TRUE(usb.latency_timer->writable);
    EXPECT_FALSE(usb.rx_trig_bytes.has_value());
    const auto uart = read_port_facts("ttyS1", root / "class" / "tty");
    EXPECT_FALSE(uart.latency_timer.has_value());
    ASSERT_TRUE(uart.rx_trig_bytes.has_value());
    EXPECT_EQ(uart.rx_trig_bytes->value, "14");
    const auto none = read_kernel_facts({}, root / "nothing");
    EXPECT_EQ(none.realtime, std::nullopt);
    EXPECT_EQ(none.unbound_cpumask, std::nullopt);
    std::filesystem::remove_all(root);
}

}  // namespace
}  // namespace drivebus::rt
