// SPDX-License-Identifier: Apache-2.0
// Who may watch and who may command, with real users: drivebusd runs as its own user, a
// viewer is in the watch group only, an operator in the control group too. The shared memory
// decides: the viewer gets no memory to write a request into, even with a program that asks
// iceoryx directly instead of going through libdrivebus.
//
// Needs root, to create the test users and groups (once; they stay) and to start each
// process as one of them with setpriv.
#include <gtest/gtest.h>

#include <grp.h>
#include <pwd.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "cannot_run.hpp"
#include "sim_process.hpp"

namespace drivebus::test {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

constexpr const char* kWatch = "dbt-watch";
constexpr const char* kControl = "dbt-control";
constexpr const char* kDaemonGroup = "dbt-daemon";
constexpr const char* kDaemonUser = "dbt-daemon";
constexpr const char* kViewer = "dbt-viewer";
constexpr const char* kOperator = "dbt-operator";

void run_or_throw(const std::vector<std::string>& argv) {
    const auto [status, out] = run_program(argv);
    if (status != 0) {
        throw std::runtime_error(argv.front() + " failed: " + out);
    }
}

// The users and groups this process created, removed again when its test ends: a machine the
// suite ran on keeps no dbt-* account. Those that existed before are left alone.
std::vector<std::string> created_users;
std::vector<std::string> created_groups;

void ensure_group(const char* name) {
    if (::getgrnam(name) == nullptr) {
        run_or_throw({"/usr/sbin/groupadd", "--system", name});
        created_groups.emplace_back(name);
    }
}

// Removes them; what is still there afterwards (a failure to report).
std::vector<std::string> remove_created() {
    std::vector<std::string> left;
    for (auto it = created_users.rbegin(); it != created_users.rend(); ++it) {
        const auto [status, out] = run_program({"/usr/sbin/userdel", *it});
        if (::getpwnam(it->c_str()) != nullptr) {
            left.push_back("user " + *it + ": " + out);
        }
    }
    for (auto it = created_groups.rbegin(); it != created_groups.rend(); ++it) {
        // userdel may have taken the group already (a group named like the user).
        const auto [status, out] = run_program({"/usr/sbin/groupdel", *it});
        if (::getgrnam(it->c_str()) != nullptr) {
            left.push_back("group " + *it + ": " + out);
        }
    }
    created_users.clear();
    created_groups.clear();
    return left;
}

// Removes them when a test ends, however it ends.
struct RemoveCreated {
    RemoveCreated() = default;
    RemoveCreated(const RemoveCreated&) = delete;
    RemoveCreated& operator=(const RemoveCreated&) = delete;
    RemoveCreated(RemoveCreated&&) = delete;
    RemoveCreated& operator=(RemoveCreated&&) = delete;
    ~RemoveCreated() {
        for (const auto& left : remove_created()) {
            ADD_FAILURE() << "not removed: " << left;
        }
    }
};

// Every user's primary group is the watch group: iceoryx's RouDi answers a process through a
// socket made with the process's effective group, so it must be RouDi's.
void ensure_user(const char* name, const std::string& extra_groups) {
    if (::getpwnam(name) == nullptr) {
        std::vector<std::string> argv = {
            "/usr/sbin/useradd", "--system", "--no-create-home", "--shell", "/usr/sbin/nologin", "--gid", kWatch};
        if (!extra_groups.empty()) {
            argv.insert(argv.end(), {"--groups", extra_groups});
        }
        argv.emplace_back(name);
        run_or_throw(argv);
        created_users.emplace_back(name);
    }
}

std::vector<std::string> as(const char* user, std::vector<std::string> argv) {
    std::vector<std::string> out = {"/usr/bin/setpriv", std::string("--reuid=") + user,
                                    std::string("--regid=") + kWatch, "--init-groups", "--"};
    out.insert(out.end(), argv.begin(), argv.end());
    return out;
}

bool roudi_file_exists() {
    std::error_code ec;
    return fs::exists("/tmp/roudi", ec);
}

// drivebus-roudi.service's roudi.toml, for the test's groups.
constexpr const char* kRouDiConfig = R"([general]
version = 1
[[segment]]
writer = "dbt-daemon"
reader = "dbt-watch"
  [[segment.mempool]]
  size = 1024
  count = 512
  [[segment.mempool]]
  size = 4096
  count = 1024
[[segment]]
writer = "dbt-control"
reader = "dbt-daemon"
  [[segment.mempool]]
  size = 512
  count = 1024
)";

class Access : public ::testing::Test {
protected:
    // The system RouDi (iox-roudi, as drivebus-roudi.service runs it) instead of an embedded one.
    [[nodiscard]] virtual bool external() const { return false; }

    void SetUp() override {
        if (::geteuid() != 0) {
            CANNOT_RUN() << "needs root to create the test users and switch to them";
        }
        for (const auto* g : {kWatch, kControl, kDaemonGroup}) {
            ensure_group(g);
        }
        ensure_user(kDaemonUser, kDaemonGroup);
        ensure_user(kViewer, "");
        ensure_user(kOperator, kControl);

        dir_ = fs::temp_directory_path() / ("drivebus-access-" + std::to_string(::getpid()));
        fs::create_directories(dir_ / "sim");
        fs::permissions(dir_, fs::perms::all);
        sim_ = std::make_unique<SimProcess>(std::vector<std::string>{"--drive", "1:atv21"}, dir_ / "sim");
        // The pty is root's: let drivebusd's user open it.
        fs::permissions(fs::canonical(sim_->link()), fs::perms::owner_read | fs::perms::owner_write |
                                                         fs::perms::group_read | fs::perms::group_write |
                                                         fs::perms::others_read | fs::perms::others_write);
        bus_ = "a" + std::to_string(::getpid());
        const auto config = dir_ / "drivebusd.toml";
        std::ofstream(config) << "[realtime]\nmode = \"off\"\nlock_memory = false\n"
                              << "[ipc]\nroudi = \"" << (external() ? "external" : "embedded") << "\"\nwatch_group = \""
                              << kWatch << "\"\ncontrol_group = \"" << kControl << "\"\ndaemon_group = \""
                              << kDaemonGroup << "\"\n"
                              << "[[bus]]\nname = \"" << bus_ << "\"\ndevice = \"" << sim_->link().string()
                              << "\"\nparity = \"none\"\nretries = 3\n"
                                 "  [[bus.drive]]\n  name = \"pump\"\n  address = 1\n  profile = \"atv21\"\n"
                                 "    [[bus.drive.poll]]\n    registers = [\"FD00\"]\n    period = \"50ms\"\n";
        fs::permissions(config, fs::perms::owner_all | fs::perms::group_read | fs::perms::others_read);
        ASSERT_FALSE(roudi_file_exists()) << "a RouDi runs already";
        if (external()) {
            const auto roudi_config = dir_ / "roudi.toml";
            std::ofstream(roudi_config) << kRouDiConfig;
            fs::permissions(roudi_config, fs::perms::owner_all | fs::perms::group_read | fs::perms::others_read);
            roudi_ = std::make_unique<Child>(as(kDaemonUser, {"/usr/bin/iox-roudi", "-c", roudi_config.string()}));
            ASSERT_TRUE(wait_until([] { return roudi_answers(); }, 10s)) << roudi_->output();
        }
        daemon_ = std::make_unique<Child>(
            as(kDaemonUser, {DRIVEBUSD_PATH, "--config", config.string(), "--profile-dir", DRIVEBUS_PROFILE_DIR}));
        ASSERT_TRUE(wait_until([&] { return daemon_->output().find("running:") != std::string::npos; }, 10s))
            << daemon_->output();
    }
    void TearDown() override {
        daemon_.reset();
        roudi_.reset();
        sim_.reset();
        std::error_code ec;
        fs::remove_all(dir_, ec);
        for (const auto& left : remove_created()) {
            ADD_FAILURE() << "not removed: " << left;
        }
    }

    std::pair<int, std::string> client(const char* user, std::vector<std::string> args) {
        args.insert(args.begin(), {TEST_CLIENT_PATH, bus_});
        return run_program(as(user, args));
    }

    fs::path dir_;
    std::string bus_;
    std::unique_ptr<SimProcess> sim_;
    std::unique_ptr<Child> roudi_;
    std::unique_ptr<Child> daemon_;
};

TEST_F(Access, TheDaemonSaysWhoMayDoWhat) {
    EXPECT_NE(daemon_->output().find("watchers: group dbt-watch, requests: group dbt-control"), std::string::npos)
        << daemon_->output();
}

TEST_F(Access, AViewerWatchesButCannotSendRequests) {
    const auto [watched, watch_out] = client(kViewer, {"snapshots", "3"});
    EXPECT_EQ(watched, 0) << watch_out;
    const auto [read, read_out] = client(kViewer, {"read", "FD00", "1"});
    EXPECT_EQ(read, 1) << read_out;
    EXPECT_NE(read_out.find("not permitted"), std::string::npos) << read_out;
    EXPECT_NE(read_out.find("dbt-control"), std::string::npos) << read_out;
}

TEST_F(Access, DrivebusctlReadsAViewersPolledRegisterFromTheSnapshot) {
    const auto [status, out] = run_program(as(kViewer, {DRIVEBUSCTL_PATH, "--bus", bus_, "read", "pump", "FD00"}));
    EXPECT_EQ(status, 0) << out;
    EXPECT_NE(out.find("from the snapshot"), std::string::npos) << out;
    EXPECT_NE(out.find("dbt-control"), std::string::npos) << out;
    EXPECT_NE(out.find("FD00"), std::string::npos) << out;
    // A register nobody polls needs a request, which the viewer may not send.
    const auto [refused, refused_out] =
        run_program(as(kViewer, {DRIVEBUSCTL_PATH, "--bus", bus_, "read", "pump", "FE03"}));
    EXPECT_EQ(refused, 4) << refused_out;
}

// Root needs no sg: drivebusctl run by root acts as the user who ran sudo (SUDO_USER), with
// that user's rights, or else as the RouDi's own user, which may watch.
TEST_F(Access, RootUsesDrivebusctlWithoutSg) {
    const auto [polled, polled_out] =
        run_program({"/usr/bin/env", "-u", "SUDO_USER", DRIVEBUSCTL_PATH, "--bus", bus_, "read", "pump", "FD00"});
    EXPECT_EQ(polled, 0) << polled_out;
    EXPECT_NE(polled_out.find("from the snapshot"), std::string::npos) << polled_out;
    const auto [listed, listed_out] = run_program({"/usr/bin/env", "-u", "SUDO_USER", DRIVEBUSCTL_PATH, "list"});
    EXPECT_EQ(listed, 0) << listed_out;
    EXPECT_NE(listed_out.find(bus_), std::string::npos) << listed_out;
    // sudo by an operator: a register nobody polls, read through a request.
    const auto [asked, asked_out] = run_program({"/usr/bin/env", std::string("SUDO_USER=") + kOperator,
                                                 DRIVEBUSCTL_PATH, "--bus", bus_, "read", "pump", "FE03"});
    EXPECT_EQ(asked, 0) << asked_out;
    EXPECT_EQ(asked_out.find("from the snapshot"), std::string::npos) << asked_out;
    // sudo by a viewer: the viewer's rights, not root's.
    const auto [refused, refused_out] = run_program(
        {"/usr/bin/env", std::string("SUDO_USER=") + kViewer, DRIVEBUSCTL_PATH, "--bus", bus_, "read", "pump", "FE03"});
    EXPECT_EQ(refused, 4) << refused_out;
    EXPECT_NE(refused_out.find("dbt-control"), std::string::npos) << refused_out;
    // A SUDO_USER that is nobody: one line, nothing done.
    const auto [nobody, nobody_out] = run_program(
        {"/usr/bin/env", "SUDO_USER=dbt-nobody-here", DRIVEBUSCTL_PATH, "--bus", bus_, "read", "pump", "FD00"});
    EXPECT_EQ(nobody, 4) << nobody_out;
    EXPECT_NE(nobody_out.find("SUDO_USER dbt-nobody-here is not a user"), std::string::npos) << nobody_out;
}

TEST_F(Access, TheSharedMemoryRefusesAViewerThatAsksIcoryxDirectly) {
    // raw_request skips libdrivebus's group check and asks iceoryx for a request chunk, to
    // write FA51 = 888: RouDi has no writable segment for the viewer.
    const auto [status, out] = run_program(as(kViewer, {RAW_REQUEST_PATH, bus_, "888"}));
    EXPECT_NE(status, 0) << out;
    EXPECT_EQ(out.find("answered"), std::string::npos) << out;
    // The operator's same program gets through, which shows the program itself works.
    const auto [ok, ok_out] = run_program(as(kOperator, {RAW_REQUEST_PATH, bus_, "777"}));
    EXPECT_EQ(ok, 0) << ok_out;
    const auto writes = sim_->command("writes 1");
    EXPECT_NE(writes.find("0xFA51=777"), std::string::npos) << writes;
    EXPECT_EQ(writes.find("0xFA51=888"), std::string::npos) << writes;
}

// The segments are files in /dev/shm that a process may try to open(2) itself, around
// iceoryx: the publications segment (named after its writer, the daemon's group) and the
// request segment (named after the control group).
TEST_F(Access, AViewerCannotOpenASegmentForWriting) {
    const std::string publications = std::string("/dev/shm/") + kDaemonGroup;
    const std::string requests = std::string("/dev/shm/") + kControl;
    const auto open_as = [&](const char* user, const std::string& path, const char* mode) {
        return run_program(as(user, {OPEN_FILE_PATH, path, mode}));
    };
    for (const auto& path : {publications, requests}) {
        const auto [status, out] = open_as(kViewer, path, "rw");
        EXPECT_EQ(status, 1) << path << ": " << out;
        EXPECT_EQ(out, "EACCES\n") << path;
    }
    // The viewer still reads the publications; the operator writes requests but not publications.
    EXPECT_EQ(open_as(kViewer, publications, "r").second, "opened\n");
    EXPECT_EQ(open_as(kOperator, requests, "rw").second, "opened\n");
    EXPECT_EQ(open_as(kOperator, publications, "rw").second, "EACCES\n");
    // And through iceoryx, all goes on as before.
    const auto [watched, watch_out] = client(kViewer, {"snapshots", "2"});
    EXPECT_EQ(watched, 0) << watch_out;
    const auto [wrote, write_out] = client(kOperator, {"writes", "FA51", "654"});
    EXPECT_EQ(wrote, 0) << write_out;
    EXPECT_EQ(sim_->command("get 1 FA51"), "ok 654");
}

// The same with the system RouDi: drivebusd, the same user, seals the segments it made.
class AccessExternal : public Access {
protected:
    [[nodiscard]] bool external() const override { return true; }
};

TEST_F(AccessExternal, AViewerCannotOpenASegmentForWriting) {
    EXPECT_NE(daemon_->output().find("system RouDi"), std::string::npos) << daemon_->output();
    EXPECT_EQ(daemon_->output().find("warning"), std::string::npos) << daemon_->output();
    for (const auto* segment : {kDaemonGroup, kControl}) {
        const auto [status, out] = run_program(as(kViewer, {OPEN_FILE_PATH, std::string("/dev/shm/") + segment, "rw"}));
        EXPECT_EQ(out, "EACCES\n") << segment;
    }
    const auto [watched, watch_out] = client(kViewer, {"snapshots", "2"});
    EXPECT_EQ(watched, 0) << watch_out;
    const auto [wrote, write_out] = client(kOperator, {"writes", "FA51", "432"});
    EXPECT_EQ(wrote, 0) << write_out;
    EXPECT_EQ(sim_->command("get 1 FA51"), "ok 432");
}

TEST_F(Access, AnotherEffectiveGroupIsToldWhichOneToUse) {
    // RouDi could not answer this process at all; the library says so at once.
    // In the watch group, but as a supplementary group only.
    const auto [status, out] = run_program(
        {"/usr/bin/setpriv", std::string("--reuid=") + kOperator, std::string("--regid=") + kControl,
         std::string("--groups=") + kWatch + "," + kControl, "--", TEST_CLIENT_PATH, bus_, "snapshots", "1"});
    EXPECT_EQ(status, 1) << out;
    EXPECT_NE(out.find("effective group must be dbt-watch"), std::string::npos) << out;
}

TEST_F(Access, OutsideTheWatchGroupIsToldToJoinIt) {
    const auto [status, out] =
        run_program({"/usr/bin/setpriv", std::string("--reuid=") + kOperator, std::string("--regid=") + kControl,
                     "--clear-groups", "--", TEST_CLIENT_PATH, bus_, "snapshots", "1"});
    EXPECT_EQ(status, 1) << out;
    EXPECT_NE(out.find("join group dbt-watch"), std::string::npos) << out;
}

TEST_F(Access, AnOperatorWatchesAndCommands) {
    const auto [watched, watch_out] = client(kOperator, {"snapshots", "3"});
    EXPECT_EQ(watched, 0) << watch_out;
    const auto [wrote, write_out] = client(kOperator, {"writes", "FA51", "321"});
    ASSERT_EQ(wrote, 0) << write_out;
    EXPECT_EQ(sim_->command("get 1 FA51"), "ok 321");
}

// An iox-roudi run as root and killed leaves its lock, socket and segments, root's, in the
// sticky /tmp and /dev/shm, where drivebusd's user may not replace them. drivebusd says in
// one line what to remove, instead of iceoryx's raw error.
TEST(StaleRouDi, TheDaemonSaysWhatToRemove) {
    const RemoveCreated remove_at_end;
    if (::geteuid() != 0) {
        CANNOT_RUN() << "needs root to leave root's files and run drivebusd as another user";
    }
    for (const auto* g : {kWatch, kControl, kDaemonGroup}) {
        ensure_group(g);
    }
    ensure_user(kDaemonUser, kDaemonGroup);
    ASSERT_FALSE(roudi_file_exists()) << "a RouDi runs already";
    const std::vector<fs::path> left = {"/tmp/iox-unique-roudi.lock", "/dev/shm/iceoryx_mgmt"};
    for (const auto& path : left) {
        ASSERT_FALSE(fs::exists(path)) << path << " is there already";
        std::ofstream{path};
        fs::permissions(path, fs::perms::owner_read | fs::perms::owner_write);
    }
    const auto dir = fs::temp_directory_path() / ("drivebus-stale-" + std::to_string(::getpid()));
    fs::create_directories(dir);
    fs::permissions(dir, fs::perms::all);
    const auto config = dir / "drivebusd.toml";
    std::ofstream(config) << "[realtime]\nmode = \"off\"\nlock_memory = false\n"
                          << "[ipc]\nroudi = \"embedded\"\nwatch_group = \"" << kWatch << "\"\ncontrol_group = \""
                          << kControl << "\"\ndaemon_group = \"" << kDaemonGroup << "\"\n"
                          << "[[bus]]\nname = \"stale\"\ndevice = \"/dev/ttyDOESNOTEXIST\"\nparity = \"none\"\n"
                             "  [[bus.drive]]\n  name = \"pump\"\n  address = 1\n  profile = \"atv21\"\n"
                             // inside the ATV21's time-out, so that the error is drivebusd's only line
                             "  keep_alive = \"1s\"\n";
    fs::permissions(config, fs::perms::owner_all | fs::perms::group_read | fs::perms::others_read);
    const auto [status, out] = run_program(
        as(kDaemonUser, {DRIVEBUSD_PATH, "--config", config.string(), "--profile-dir", DRIVEBUS_PROFILE_DIR}));
    std::error_code ec;
    for (const auto& path : left) {
        fs::remove(path, ec);
    }
    fs::remove_all(dir, ec);
    EXPECT_EQ(status, 1) << out;
    EXPECT_EQ(std::count(out.begin(), out.end(), '\n'), 1) << out;
    EXPECT_NE(out.find("a RouDi of user root left files"), std::string::npos) << out;
    EXPECT_NE(out.find("sudo rm /tmp/iox-unique-roudi.lock /dev/shm/iceoryx_mgmt"), std::string::npos) << out;
    EXPECT_EQ(out.find("iceoryx"), out.find("iceoryx_mgmt")) << "a raw iceoryx line: " << out;
}

}  // namespace
}  // namespace drivebus::test
