// SPDX-License-Identifier: Apache-2.0
// The documentation of the configuration file against the tables the reader reads it by
// (config/reference.hpp), through tests/support/doc_reference.hpp: docs/configuration.md and
// drivebusd.toml(5); and the reader takes every key its tables list and no other.
#include "config/reference.hpp"

#include <gtest/gtest.h>

#include <string>
#include <string_view>
#include <vector>

#include "config/config.hpp"
#include "doc_reference.hpp"

namespace drivebus::config {
namespace {

constexpr std::string_view kDoc = "docs/configuration.md";
constexpr std::string_view kMan = "man/drivebusd.toml.5";

TEST(ConfigReference, SectionsInReadingOrderWithUniqueKeys) {
    const auto sections = reference();
    docs::expect_well_formed(sections);
    std::vector<std::string> names;
    for (const auto& section : sections) {
        names.push_back(section.name);
    }
    EXPECT_EQ(names, (std::vector<std::string>{"[realtime]", "[ipc]", "[[bus]]", "direction = \"kernel\"",
                                               "direction = \"gpio\"", "[[bus.drive]]", "[[bus.drive.poll]]"}));
}

TEST(ConfigReference, TheDocumentationHasEveryKeyWithTheReadersTypeDefaultAndRange) {
    docs::expect_documented(kDoc, reference());
}

TEST(ConfigReference, TheManPageIntroducesEveryKeyUnderItsSection) {
    docs::expect_in_man_page(kMan, reference());
}

// ---- the reader takes what the tables list ----

// A valid file with `key = value` in `section`, in place of any line of that key.
std::string with(const SectionReference& section, const std::string& key, const std::string& value) {
    std::vector<std::string> top;
    std::vector<std::string> bus = {"name = \"line1\"", "device = \"/dev/ttyUSB0\""};
    std::vector<std::string> drive = {"name = \"pump\"", "address = 1", "profile = \"atv21\""};
    std::vector<std::string> poll = {"name = \"fast\"", "registers = [\"FD00\"]", "period = \"100ms\""};
    const auto& name = section.name;
    auto& lines = name == "[realtime]" || name == "[ipc]" ? top
                  : name == "[[bus.drive]]"               ? drive
                  : name == "[[bus.drive.poll]]"          ? poll
                                                          : bus;  // and the keys of a direction
    if (!key.empty()) {
        std::erase_if(lines, [&](const std::string& line) { return line.starts_with(key + " ="); });
        lines.push_back(key + " = " + value);
    }
    const auto table = [](std::string_view header, const std::vector<std::string>& body) {
        std::string out(header);
        for (const auto& line : body) {
            out += "\n" + line;
        }
        return out + "\n";
    };
    return (top.empty() ? "" : table(name, top)) + table("[[bus]]", bus) + table("[[bus.drive]]", drive) +
           table("[[bus.drive.poll]]", poll);
}

// Each key of each table given a value of no key's type (a date): the error is about that key
// and never "unknown key", while a key no table lists is one.
TEST(ConfigReference, TheReaderTakesEveryKeyOfTheTablesAndNoOther) {
    for (const auto& section : reference()) {
        ASSERT_TRUE(parse_config(with(section, "", ""), "test.toml")) << section.name;
        for (const auto& key : section.keys) {
            const auto config = parse_config(with(section, key.key, "2024-01-01"), "test.toml");
            ASSERT_FALSE(config) << section.name << ": key " << key.key << " = a date was accepted";
            EXPECT_EQ(config.error().message.find("unknown key"), std::string::npos)
                << section.name << ": " << config.error().message;
            EXPECT_NE(config.error().message.find(key.key), std::string::npos)
                << section.name << ": " << config.error().message;
        }
        const auto config = parse_config(with(section, "no_such_key", "1"), "test.toml");
        ASSERT_FALSE(config) << section.name;
        EXPECT_NE(config.error().message.find("unknown key 'no_such_key'"), std::string::npos)
            << section.name << ": " << config.error().message;
    }
}

}  // namespace
}  // namespace drivebus::config
