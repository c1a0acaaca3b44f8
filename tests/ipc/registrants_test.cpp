// SPDX-License-Identifier: Apache-2.0
// Which registered runtimes drivebusd can place in its PID namespace (judge_registrant, on a
// /proc written by the test), and the list of registrants that keeps the lock reaper from
// acting while one it cannot place is connected.
#include <gtest/gtest.h>

#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>

#include "ipc/registrants.hpp"

namespace drivebus::ipc {
namespace {

using namespace std::chrono_literals;
namespace fs = std::filesystem;

// A /proc of the test's making: PID/status (Uid, NSpid) and PID/stat (start time, field 22).
class FakeProc {
public:
    FakeProc()
        : root_(fs::temp_directory_path() /
                ("drivebus-fakeproc-" + std::to_string(::getpid()) + "-" + std::to_string(counter_++))) {
        fs::create_directories(root_);
        add("self", "1000", 0, 1);
    }
    ~FakeProc() {
        std::error_code ec;
        fs::remove_all(root_, ec);
    }
    FakeProc(const FakeProc&) = delete;
    FakeProc& operator=(const FakeProc&) = delete;
    FakeProc(FakeProc&&) = delete;
    FakeProc& operator=(FakeProc&&) = delete;

    // `nspid`: as /proc writes it, "HOST" or "HOST CHILD ...".
    void add(const std::string& name, const std::string& nspid, uid_t uid, std::uint64_t start,
             const std::string& comm = "app") {
        const auto dir = root_ / name;
        fs::create_directories(dir);
        std::ofstream(dir / "status") << "Name:\t" << comm << "\nUid:\t" << uid << '\t' << uid << '\t' << uid << '\t'
                                      << uid << "\nNSpid:\t" << nspid << '\n';
        std::ofstream stat(dir / "stat");
        stat << name << " (" << comm << ") S";
        for (int field = 4; field <= 21; ++field) {
            stat << ' ' << field;
        }
        stat << ' ' << start << " 9999 0\n";
    }
    [[nodiscard]] const fs::path& root() const { return root_; }

private:
    static inline int counter_ = 0;
    fs::path root_;
};

TEST(JudgeRegistrant, AProcessOfThisNamespaceIsPlaced) {
    FakeProc proc;
    proc.add("200", "200", 1000, 50);
    EXPECT_EQ(judge_registrant(200, 1000, 60, proc.root(), true), std::nullopt);
}

TEST(JudgeRegistrant, ANameWithSpacesAndParenthesesDoesNotHideTheStartTime) {
    FakeProc proc;
    proc.add("200", "200", 1000, 50, "a) b (c");
    EXPECT_EQ(judge_registrant(200, 1000, 60, proc.root(), true), std::nullopt);
    EXPECT_NE(judge_registrant(200, 1000, 40, proc.root(), true), std::nullopt);
}

TEST(JudgeRegistrant, APidThatIsNotHereIsNotPlaced) {
    FakeProc proc;
    const auto why = judge_registrant(4000001, 1000, 60, proc.root(), true);
    ASSERT_TRUE(why);
    EXPECT_NE(why->find("no process 4000001"), std::string::npos) << *why;
}

// A client in a container numbers itself 7; on the host, 7 is some other process of the same
// user, and the container's process shows as 5000 with NSpid "5000 7".
TEST(JudgeRegistrant, AContainersRuntimeIsNotPlacedWhereTheHostHasItsPid) {
    FakeProc proc;
    proc.add("7", "7", 1000, 5);
    proc.add("5000", "5000 7", 1000, 50);
    const auto why = judge_registrant(7, 1000, 60, proc.root(), true);
    ASSERT_TRUE(why);
    EXPECT_NE(why->find("process 5000 here has pid 7 in a PID namespace below"), std::string::npos) << *why;
}

TEST(JudgeRegistrant, AnotherUsersProcessIsNotTheRuntime) {
    FakeProc proc;
    proc.add("200", "200", 0, 50);
    const auto why = judge_registrant(200, 1000, 60, proc.root(), true);
    ASSERT_TRUE(why);
    EXPECT_NE(why->find("not of user 1000"), std::string::npos) << *why;
}

TEST(JudgeRegistrant, AProcessStartedAfterTheRegistrationHasTheRuntimesPidAgain) {
    FakeProc proc;
    proc.add("200", "200", 1000, 70);
    const auto why = judge_registrant(200, 1000, 60, proc.root(), true);
    ASSERT_TRUE(why);
    EXPECT_NE(why->find("started after"), std::string::npos) << *why;
}

TEST(JudgeRegistrant, AProcessInAnotherNamespaceIsNotPlaced) {
    FakeProc proc;
    proc.add("200", "200 3", 1000, 50);
    const auto why = judge_registrant(200, 1000, 60, proc.root(), true);
    ASSERT_TRUE(why);
    EXPECT_NE(why->find("another PID namespace"), std::string::npos) << *why;
}

TEST(JudgeRegistrant, AProcThatHidesOtherUsersPlacesNobody) {
    FakeProc proc;
    proc.add("200", "200", 1000, 50);
    const auto why = judge_registrant(200, 1000, 60, proc.root(), false);
    ASSERT_TRUE(why);
    EXPECT_NE(why->find("hides other users"), std::string::npos) << *why;
}

TEST(JudgeRegistrant, ThisProcessOnTheRealProcIsPlaced) {
    EXPECT_EQ(judge_registrant(::getpid(), ::getuid(), boot_ticks_now(), "/proc", proc_shows_everyone()), std::nullopt);
}

constexpr auto kSilence = 1500ms;
const Registrants::Clock::time_point t0{};
const std::optional<std::string> placed = std::nullopt;
const std::optional<std::string> not_here = "not here";

TEST(Registrants, NobodyRegisteredRefusesNothing) {
    Registrants list(kSilence);
    EXPECT_EQ(list.refusal(), std::nullopt);
}

TEST(Registrants, PlacedRuntimesRefuseNothing) {
    Registrants list(kSilence);
    list.registered("drivebusd", 100, placed, t0);
    list.registered("app-1", 101, placed, t0);
    EXPECT_EQ(list.refusal(), std::nullopt);
    EXPECT_EQ(list.size(), 2U);
}

TEST(Registrants, ARuntimeNotPlacedRefusesUntilItSaysGoodbye) {
    Registrants list(kSilence);
    list.registered("app-1", 100, placed, t0);
    list.registered("app-7", 4000001, not_here, t0);
    const Refusal want{"app-7", 4000001, "not here"};
    EXPECT_EQ(list.refusal(), want);
    EXPECT_EQ(list.refusal(), want);
    list.left("app-7");
    EXPECT_EQ(list.refusal(), std::nullopt);
    EXPECT_EQ(list.size(), 1U);
}

// RouDi takes a runtime for gone after its keep-alives stop; so does the list, but only while
// others are still heard: when RouDi's message thread is held up, nobody is heard.
TEST(Registrants, ARuntimeNotPlacedIsForgottenOnceQuietWhileOthersAreHeard) {
    Registrants list(kSilence);
    list.registered("drivebusd", 100, placed, t0);
    list.registered("app-7", 4000001, not_here, t0);
    list.heard("app-7", t0 + 1s);
    EXPECT_TRUE(list.refusal());
    list.heard("drivebusd", t0 + 2s);
    EXPECT_TRUE(list.refusal()) << "quiet for 1 s only";
    list.heard("drivebusd", t0 + 2600ms);
    EXPECT_EQ(list.refusal(), std::nullopt);
    EXPECT_EQ(list.size(), 1U);
}

TEST(Registrants, NobodyIsForgottenWhileNobodyIsHeard) {
    Registrants list(kSilence);
    list.registered("drivebusd", 100, placed, t0);
    list.registered("app-7", 4000001, not_here, t0 + 1s);
    for (int i = 0; i < 3; ++i) {
        EXPECT_TRUE(list.refusal());
    }
    EXPECT_EQ(list.size(), 2U);
}

TEST(Registrants, ARuntimeRegisteredAgainTakesItsNewVerdict) {
    Registrants list(kSilence);
    list.registered("app", 4000001, not_here, t0);
    EXPECT_TRUE(list.refusal());
    list.registered("app", 100, placed, t0 + 1s);
    EXPECT_EQ(list.refusal(), std::nullopt);
    list.registered("app", 4000002, "elsewhere", t0 + 2s);
    EXPECT_EQ(list.refusal(), (Refusal{"app", 4000002, "elsewhere"}));
}

}  // namespace
}  // namespace drivebus::ipc
