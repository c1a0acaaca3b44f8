// SPDX-License-Identifier: Apache-2.0
// The journal path without journald: the fields one message becomes (names journald accepts,
// MESSAGE on one line, BUS and DRIVE when known, where in the code), and the choice between the
// journal and stderr that JOURNAL_STREAM makes, seen through a backend that records instead of
// sending.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "log/log.hpp"

namespace drivebus::test {
namespace {

// journald's rules for a field name a client may set (sd_journal_sendv refuses others): upper
// case letters, digits and underscores, not starting with an underscore or a digit, at most 64.
bool valid_field_name(std::string_view name) {
    if (name.empty() || name.size() > 64 || name.front() == '_' || (name.front() >= '0' && name.front() <= '9')) {
        return false;
    }
    return std::ranges::all_of(name,
                               [](char c) { return (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_'; });
}

std::optional<std::string> field(const std::vector<std::string>& fields, std::string_view name) {
    for (const auto& f : fields) {
        if (f.starts_with(std::string(name) + "=")) {
            return f.substr(name.size() + 1);
        }
    }
    return std::nullopt;
}

TEST(JournalFields, EveryFieldWithANameJournaldAccepts) {
    const auto here = std::source_location::current();
    const log::Entry entry{log::Level::Warning, "bus line1 drive pump: not answering", {"line1", "pump"}, here};
    const auto fields = log::journal_fields("drivebusd", entry);
    for (const auto& f : fields) {
        const auto equals = f.find('=');
        ASSERT_NE(equals, std::string::npos) << f;
        EXPECT_TRUE(valid_field_name(std::string_view(f).substr(0, equals))) << f;
    }
    EXPECT_EQ(field(fields, "MESSAGE"), "bus line1 drive pump: not answering");
    EXPECT_EQ(field(fields, "PRIORITY"), "4");
    EXPECT_EQ(field(fields, "SYSLOG_IDENTIFIER"), "drivebusd");
    EXPECT_EQ(field(fields, "BUS"), "line1");
    EXPECT_EQ(field(fields, "DRIVE"), "pump");
    std::string_view file = here.file_name();  // "../../../tests/log/journal_test.cpp" in a build tree
    while (file.starts_with("../") || file.starts_with("./")) {
        file.remove_prefix(file.find('/') + 1);
    }
    EXPECT_EQ(field(fields, "CODE_FILE"), file);
    EXPECT_TRUE(file.ends_with("tests/log/journal_test.cpp")) << file;
    EXPECT_EQ(field(fields, "CODE_LINE"), std::to_string(here.line()));
    EXPECT_EQ(field(fields, "CODE_FUNC"), here.function_name());
}

TEST(JournalFields, NoCodeFieldsWithoutAPlace) {
    const std::source_location nowhere{};
    const auto fields = log::journal_fields("drivebusd", {log::Level::Info, "x", {}, nowhere});
    EXPECT_FALSE(field(fields, "CODE_FILE"));
    EXPECT_FALSE(field(fields, "CODE_LINE"));
    EXPECT_FALSE(field(fields, "CODE_FUNC"));
}

TEST(JournalFields, NoBusOrDriveFieldWhenTheMessageConcernsNone) {
    const auto fields = log::journal_fields("drivebusd", {log::Level::Notice, "running", {}, {}});
    EXPECT_FALSE(field(fields, "BUS"));
    EXPECT_FALSE(field(fields, "DRIVE"));
    EXPECT_FALSE(field(fields, "CODE_FILE")) << "no location known";
    EXPECT_EQ(field(fields, "PRIORITY"), "5");
    const auto only_bus = log::journal_fields("drivebusd", {log::Level::Error, "bus down", {.bus = "line2"}, {}});
    EXPECT_EQ(field(only_bus, "BUS"), "line2");
    EXPECT_FALSE(field(only_bus, "DRIVE"));
}

// The message stays one line (a client's name could otherwise forge a line in plain stderr
// and in `journalctl -o cat`); other values go as they are, which the native protocol carries.
TEST(JournalFields, TheMessageStaysOneLine) {
    const auto fields =
        log::journal_fields("drivebusd", {log::Level::Info, "lease of pump\n<3>forged\x1B[2J", {"a\nb", ""}, {}});
    EXPECT_EQ(field(fields, "MESSAGE"), "lease of pump\\x0A<3>forged\\x1B[2J");
    EXPECT_EQ(field(fields, "BUS"), "a\nb");
}

TEST(JournalStream, MatchesOnlyStderrsDeviceAndInode) {
    EXPECT_TRUE(log::is_journal_stream("8:12345", 8, 12345));
    EXPECT_TRUE(log::is_journal_stream("18446744073709551615:1", 18446744073709551615ULL, 1));
    EXPECT_FALSE(log::is_journal_stream("8:12346", 8, 12345)) << "another stream: stderr was redirected";
    EXPECT_FALSE(log::is_journal_stream("9:12345", 8, 12345));
    EXPECT_FALSE(log::is_journal_stream(nullptr, 8, 12345));
    for (const char* bad : {"", "8", "8:", ":12345", "8:12345x", "x8:12345", "8;12345", "-8:12345"}) {
        EXPECT_FALSE(log::is_journal_stream(bad, 8, 12345)) << bad;
    }
}

class Recorder final : public log::Backend {
public:
    int send(std::span<const iovec> fields) noexcept override {
        std::vector<std::string> copy;
        for (const auto& v : fields) {
            copy.emplace_back(static_cast<const char*>(v.iov_base), v.iov_len);
        }
        sent.push_back(std::move(copy));
        return refuse;
    }
    void print(std::string_view line) noexcept override { printed.emplace_back(line); }

    int refuse = 0;
    std::vector<std::vector<std::string>> sent;
    std::vector<std::string> printed;
};

// JOURNAL_STREAM as systemd would set it when stderr (here: whatever the test's stderr is) is
// the journal, or naming another stream.
class LogSink : public ::testing::Test {
protected:
    void SetUp() override {
        struct stat err{};
        ASSERT_EQ(::fstat(STDERR_FILENO, &err), 0);
        matching = std::to_string(err.st_dev) + ":" + std::to_string(err.st_ino);
        other = std::to_string(err.st_dev) + ":" + std::to_string(err.st_ino + 1);
        log::set_backend(&recorder);
    }
    void TearDown() override {
        log::set_backend(nullptr);
        ::unsetenv("JOURNAL_STREAM");
        log::init("drivebusd", log::Level::Info);
    }
    static void init_with(const std::optional<std::string>& stream) {
        if (stream) {
            ::setenv("JOURNAL_STREAM", stream->c_str(), 1);
        } else {
            ::unsetenv("JOURNAL_STREAM");
        }
        log::init("drivebusd", log::Level::Debug);
    }

    Recorder recorder;
    std::string matching;
    std::string other;
};

TEST_F(LogSink, WhenStderrIsTheJournalTheMessageGoesWithItsFields) {
    init_with(matching);
    EXPECT_TRUE(log::to_journal());
    log::warning("bus line1 drive pump: not answering", {.bus = "line1", .drive = "pump"});
    EXPECT_TRUE(recorder.printed.empty());
    ASSERT_EQ(recorder.sent.size(), 1U);
    const auto& fields = recorder.sent[0];
    EXPECT_EQ(field(fields, "MESSAGE"), "bus line1 drive pump: not answering");
    EXPECT_EQ(field(fields, "PRIORITY"), "4");
    EXPECT_EQ(field(fields, "BUS"), "line1");
    EXPECT_EQ(field(fields, "DRIVE"), "pump");
    EXPECT_TRUE(field(fields, "CODE_FILE").value_or("").ends_with("tests/log/journal_test.cpp"))
        << "the caller's file, not the logger's";
}

TEST_F(LogSink, WhatJournaldRefusesGoesToStderrWithItsPriority) {
    init_with(matching);
    recorder.refuse = -ECONNREFUSED;
    log::error("bus line1: device gone", {.bus = "line1"});
    EXPECT_EQ(recorder.sent.size(), 1U);
    ASSERT_EQ(recorder.printed.size(), 1U);
    EXPECT_EQ(recorder.printed[0], "<3>bus line1: device gone\n");
}

TEST_F(LogSink, WhenStderrIsAnotherStreamLinesArePlain) {
    for (const auto& stream : {std::optional<std::string>(other), std::optional<std::string>()}) {
        recorder.sent.clear();
        recorder.printed.clear();
        init_with(stream);
        EXPECT_FALSE(log::to_journal()) << stream.value_or("(unset)");
        log::notice("bus line1: open", {.bus = "line1"});
        EXPECT_TRUE(recorder.sent.empty());
        ASSERT_EQ(recorder.printed.size(), 1U);
        EXPECT_EQ(recorder.printed[0], "drivebusd: notice: bus line1: open\n");
    }
}

TEST_F(LogSink, AThreadsFieldsApplyWhereTheCallGivesNone) {
    init_with(matching);
    {
        const log::ThreadFields bus({.bus = "line1"});
        log::info("bus line1: open");
        log::info("bus line1 drive fan: answering", {.drive = "fan"});
        log::info("elsewhere", {.bus = "line2"});
    }
    log::info("after");
    ASSERT_EQ(recorder.sent.size(), 4U);
    EXPECT_EQ(field(recorder.sent[0], "BUS"), "line1");
    EXPECT_EQ(field(recorder.sent[1], "BUS"), "line1");
    EXPECT_EQ(field(recorder.sent[1], "DRIVE"), "fan");
    EXPECT_EQ(field(recorder.sent[2], "BUS"), "line2");
    EXPECT_FALSE(field(recorder.sent[3], "BUS"));
}

// A real-time thread's line carries its fields and place through the ring, without allocating
// (the ring's line is of fixed size).
TEST_F(LogSink, ARingLineKeepsItsFieldsAndPlace) {
    init_with(matching);
    log::Ring ring(8, false);
    std::uint32_t line = 0;
    std::thread bus_thread([&] {
        ring.use_on_this_thread();
        const log::ThreadFields bus({.bus = "line1"});
        line = std::source_location::current().line() + 1;
        log::warning("bus line1 drive pump: late reply", {.drive = "pump"});
    });
    bus_thread.join();
    EXPECT_TRUE(recorder.sent.empty()) << "written by the real-time thread itself";
    ring.drain();
    ASSERT_EQ(recorder.sent.size(), 1U);
    const auto& fields = recorder.sent[0];
    EXPECT_EQ(field(fields, "MESSAGE"), "bus line1 drive pump: late reply");
    EXPECT_EQ(field(fields, "BUS"), "line1");
    EXPECT_EQ(field(fields, "DRIVE"), "pump");
    EXPECT_EQ(field(fields, "CODE_LINE"), std::to_string(line));
}

}  // namespace
}  // namespace drivebus::test
