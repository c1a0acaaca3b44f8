// SPDX-License-Identifier: Apache-2.0
// The documentation of the configuration file against the tables the reader reads it by
// (config/reference.hpp), through tests/support/doc_reference.hpp: docs/configuration.md and
// drivebusd.toml(5); and the reader takes every key its tables list and no other.
#include "config/reference.hpp"

#include <gtest/gtest.h>

#include <optional>
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

TEST(ConfigReference, TheReaderTakesEveryKeyOfTheTablesAndNoOther) {
    docs::expect_reader_takes_every_key(reference(), with, [](const std::string& text) -> std::optional<std::string> {
        auto config = parse_config(text, "test.toml");
        return config ? std::nullopt : std::optional(config.error().message);
    });
}

}  // namespace
}  // namespace drivebus::config
