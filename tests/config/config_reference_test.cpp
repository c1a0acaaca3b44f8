// SPDX-License-Identifier: Apache-2.0
// The documentation of the configuration file against the tables the reader reads it by
// (config/reference.hpp): docs/configuration.md has a row for every key of each section, with
// the reader's type, default and range, and drivebusd.toml(5) introduces every key under its
// section; neither names a key the reader does not take there.
#include "config/reference.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstddef>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include "config/config.hpp"

namespace drivebus::config {
namespace {

namespace fs = std::filesystem;

constexpr std::string_view kDoc = "docs/configuration.md";
constexpr std::string_view kMan = "man/drivebusd.toml.5";

std::vector<std::string> lines_of(std::string_view name) {
    std::ifstream in(fs::path(DRIVEBUS_TEST_SOURCE_DIR) / name);
    EXPECT_TRUE(in) << "cannot read " << name;
    std::vector<std::string> lines;
    for (std::string line; std::getline(in, line);) {
        lines.push_back(line);
    }
    return lines;
}

// "docs/configuration.md:123".
std::string at(std::string_view file, std::size_t index) {
    return std::string(file) + ":" + std::to_string(index + 1);
}

// The reference section named in `heading`, or nullptr: "[[bus]]" in "## `[[bus]]` (at least
// one)", but not in "## `[[bus.drive]]`".
const SectionReference* section_in(std::string_view heading, const std::vector<SectionReference>& sections) {
    const SectionReference* found = nullptr;
    for (const auto& section : sections) {
        if (heading.find(section.name) != std::string_view::npos) {
            if (found != nullptr) {
                ADD_FAILURE() << "heading '" << heading << "' names both " << found->name << " and " << section.name;
            }
            found = &section;
        }
    }
    return found;
}

// What the reader says of a key: "integer, default 2, 0-10".
std::string said(const KeyReference& key) {
    return key.type + (key.default_value == "required" ? ", required" : ", default " + key.default_value) +
           (key.range.empty() ? "" : ", " + key.range);
}

// ---- docs/configuration.md ----

// A cell as plain text: no `code` or **bold** marks, no blanks around it.
std::string plain(std::string_view cell) {
    std::string out;
    for (std::size_t i = 0; i < cell.size(); ++i) {
        if (cell.substr(i, 2) == "**") {
            ++i;
        } else if (cell[i] != '`') {
            out += cell[i];
        }
    }
    const auto first = out.find_first_not_of(' ');
    return first == std::string::npos ? "" : out.substr(first, out.find_last_not_of(' ') - first + 1);
}

// "| a | b |" -> {"a", "b"}.
std::vector<std::string> cells(std::string_view row) {
    std::vector<std::string> out;
    std::size_t from = 1;
    for (auto bar = row.find('|', from); bar != std::string_view::npos; bar = row.find('|', from)) {
        out.push_back(plain(row.substr(from, bar - from)));
        from = bar + 1;
    }
    return out;
}

struct DocRow {
    std::size_t line;
    std::vector<std::string> cells;  // key, type, default, range / values, meaning
};

// Section name -> key -> its row, for the sections reference() has. A section's rows are those of
// the tables under its heading, up to the next heading.
std::map<std::string, std::map<std::string, DocRow>> doc_tables(const std::vector<SectionReference>& sections) {
    const auto lines = lines_of(kDoc);
    std::map<std::string, std::map<std::string, DocRow>> tables;
    const SectionReference* section = nullptr;
    for (std::size_t i = 0; i < lines.size(); ++i) {
        const std::string_view line = lines[i];
        if (line.starts_with("#")) {
            // The heading's first code span names the section: "## `[realtime]` (optional)".
            const auto open = line.find('`');
            const auto close = open == std::string_view::npos ? open : line.find('`', open + 1);
            section =
                close == std::string_view::npos ? nullptr : section_in(line.substr(open, close - open + 1), sections);
            if (section != nullptr) {
                tables[section->name];  // present, even without a table
            }
            continue;
        }
        if (section == nullptr || !line.starts_with("|")) {
            continue;
        }
        auto row = cells(line);
        if (row.at(0) == "key") {
            EXPECT_EQ(line, "| key | type | default | range / values | meaning |")
                << at(kDoc, i) << ": section " << section->name << ": the table's columns";
        } else if (!line.starts_with("|---")) {
            const auto key = row.at(0);
            EXPECT_EQ(row.size(), 5U) << at(kDoc, i) << ": section " << section->name << ", key " << key
                                      << ": a row has 5 cells";
            row.resize(5);
            const auto [it, fresh] = tables[section->name].emplace(key, DocRow{i, std::move(row)});
            EXPECT_TRUE(fresh) << at(kDoc, i) << ": section " << section->name << ": key " << key
                               << " has a row already, at " << at(kDoc, it->second.line);
        }
    }
    return tables;
}

// The documentation's default states the reader's, and may go on to explain it: `none` (any CPU).
bool same_default(std::string_view documented, std::string_view read) {
    return documented == read || (documented.starts_with(read) && documented[read.size()] == ' ');
}

TEST(ConfigReference, SectionsInReadingOrderWithUniqueKeys) {
    const auto sections = reference();
    std::vector<std::string> names;
    for (const auto& section : sections) {
        names.push_back(section.name);
        std::set<std::string> keys;
        for (const auto& key : section.keys) {
            EXPECT_TRUE(keys.insert(key.key).second) << section.name << ": key " << key.key << " twice";
            EXPECT_FALSE(key.type.empty() || key.default_value.empty() || key.doc.empty())
                << section.name << ": key " << key.key << " lacks a type, a default or a line of doc";
        }
        EXPECT_FALSE(keys.empty()) << section.name;
    }
    EXPECT_EQ(names, (std::vector<std::string>{"[realtime]", "[ipc]", "[[bus]]", "direction = \"kernel\"",
                                               "direction = \"gpio\"", "[[bus.drive]]", "[[bus.drive.poll]]"}));
}

TEST(ConfigReference, TheDocumentationHasEveryKeyWithTheReadersTypeDefaultAndRange) {
    const auto sections = reference();
    auto tables = doc_tables(sections);
    for (const auto& section : sections) {
        const auto found = tables.find(section.name);
        if (found == tables.end()) {
            ADD_FAILURE() << kDoc << ": no section " << section.name << " (a heading \"## `" << section.name << "`\")";
            continue;
        }
        auto& rows = found->second;
        for (const auto& key : section.keys) {
            const auto row = rows.find(key.key);
            if (row == rows.end()) {
                ADD_FAILURE() << kDoc << ": section " << section.name << " has no row for key " << key.key
                              << "; the reader takes it: " << said(key);
                continue;
            }
            const auto& doc = row->second.cells;
            const auto where = at(kDoc, row->second.line) + ": section " + section.name + ", key " + key.key;
            EXPECT_EQ(doc[1], key.type) << where << ": the type is '" << doc[1] << "' in the documentation, '"
                                        << key.type << "' in the reader";
            EXPECT_TRUE(same_default(doc[2], key.default_value))
                << where << ": the default is '" << doc[2] << "' in the documentation, '" << key.default_value
                << "' in the reader";
            EXPECT_TRUE(doc[3].find(key.range) != std::string::npos)
                << where << ": the range / values '" << doc[3] << "' do not state the reader's '" << key.range << "'";
            rows.erase(row);
        }
        for (const auto& [name, row] : rows) {
            ADD_FAILURE() << at(kDoc, row.line) << ": section " << section.name << " has a row for key " << name
                          << ", which the reader does not take there";
        }
    }
}

// ---- man/drivebusd.toml.5 ----

// Section name -> the keys the page introduces under it (".TP", then ".B key") -> their line.
std::map<std::string, std::map<std::string, std::size_t>> man_keys(const std::vector<SectionReference>& sections) {
    const auto lines = lines_of(kMan);
    std::map<std::string, std::map<std::string, std::size_t>> keys;
    const SectionReference* section = nullptr;
    for (std::size_t i = 0; i < lines.size(); ++i) {
        const std::string_view line = lines[i];
        if (line.starts_with(".SH ") || line.starts_with(".SS ")) {
            // .SS "With direction = \(dqkernel\(dq only"
            std::string heading(line.substr(4));
            for (auto q = heading.find("\\(dq"); q != std::string::npos; q = heading.find("\\(dq")) {
                heading.replace(q, 4, "\"");
            }
            section = section_in(heading, sections);
            if (section != nullptr) {
                keys[section->name];
            }
            continue;
        }
        if (section == nullptr || line != ".TP" || i + 1 == lines.size() || !lines[i + 1].starts_with(".B ")) {
            continue;
        }
        const auto key = lines[i + 1].substr(3);
        if (std::ranges::all_of(key, [](char c) { return (c >= 'a' && c <= 'z') || c == '_'; })) {
            const auto [it, fresh] = keys[section->name].emplace(key, i + 1);
            EXPECT_TRUE(fresh) << at(kMan, i + 1) << ": section " << section->name << ": key " << key
                               << " is introduced already, at " << at(kMan, it->second);
        }
    }
    return keys;
}

TEST(ConfigReference, TheManPageIntroducesEveryKeyUnderItsSection) {
    const auto sections = reference();
    auto keys = man_keys(sections);
    for (const auto& section : sections) {
        const auto found = keys.find(section.name);
        if (found == keys.end()) {
            ADD_FAILURE() << kMan << ": no section " << section.name << " (a .SH or .SS heading naming it)";
            continue;
        }
        auto& introduced = found->second;
        for (const auto& key : section.keys) {
            if (introduced.erase(key.key) == 0) {
                ADD_FAILURE() << kMan << ": section " << section.name << " does not introduce key " << key.key
                              << " (.TP, then .B " << key.key << "); the reader takes it: " << said(key);
            }
        }
        for (const auto& [name, line] : introduced) {
            ADD_FAILURE() << at(kMan, line) << ": section " << section.name << " introduces key " << name
                          << ", which the reader does not take there";
        }
    }
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
