// SPDX-License-Identifier: Apache-2.0
#include "doc_reference.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstddef>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <string>

namespace drivebus::docs {
namespace {

namespace fs = std::filesystem;
using settings::KeyReference;
using settings::SectionReference;

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
std::map<std::string, std::map<std::string, DocRow>> doc_tables(std::string_view doc,
                                                                const std::vector<SectionReference>& sections) {
    const auto lines = lines_of(doc);
    std::map<std::string, std::map<std::string, DocRow>> tables;
    const SectionReference* section = nullptr;
    for (std::size_t i = 0; i < lines.size(); ++i) {
        const std::string_view line = lines[i];
        if (line.starts_with("#")) {
            // The heading's first code span names the section: "## `[realtime]` (optional)"; a
            // heading without one, in its words: "### The top level".
            const auto open = line.find('`');
            const auto close = open == std::string_view::npos ? open : line.find('`', open + 1);
            section =
                section_in(close == std::string_view::npos ? line : line.substr(open, close - open + 1), sections);
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
                << at(doc, i) << ": section " << section->name << ": the table's columns";
        } else if (!line.starts_with("|---")) {
            const auto key = row.at(0);
            EXPECT_EQ(row.size(), 5U) << at(doc, i) << ": section " << section->name << ", key " << key
                                      << ": a row has 5 cells";
            row.resize(5);
            const auto [it, fresh] = tables[section->name].emplace(key, DocRow{i, std::move(row)});
            EXPECT_TRUE(fresh) << at(doc, i) << ": section " << section->name << ": key " << key
                               << " has a row already, at " << at(doc, it->second.line);
        }
    }
    return tables;
}

// The documentation's default states the reader's, and may go on to explain it: `none` (any CPU).
bool same_default(std::string_view documented, std::string_view read) {
    return documented == read || (documented.starts_with(read) && documented[read.size()] == ' ');
}

// Section name -> the keys the page introduces under it (".TP", then ".B key") -> their line.
std::map<std::string, std::map<std::string, std::size_t>> man_keys(std::string_view man,
                                                                   const std::vector<SectionReference>& sections) {
    const auto lines = lines_of(man);
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
            EXPECT_TRUE(fresh) << at(man, i + 1) << ": section " << section->name << ": key " << key
                               << " is introduced already, at " << at(man, it->second);
        }
    }
    return keys;
}

}  // namespace

void expect_well_formed(const std::vector<SectionReference>& sections) {
    for (const auto& section : sections) {
        std::set<std::string> keys;
        for (const auto& key : section.keys) {
            EXPECT_TRUE(keys.insert(key.key).second) << section.name << ": key " << key.key << " twice";
            EXPECT_FALSE(key.type.empty() || key.default_value.empty() || key.doc.empty())
                << section.name << ": key " << key.key << " lacks a type, a default or a line of doc";
        }
        EXPECT_FALSE(keys.empty()) << section.name;
    }
}

void expect_documented(std::string_view doc, const std::vector<SectionReference>& sections) {
    auto tables = doc_tables(doc, sections);
    for (const auto& section : sections) {
        const auto found = tables.find(section.name);
        if (found == tables.end()) {
            ADD_FAILURE() << doc << ": no section " << section.name << " (a heading \"## `" << section.name << "`\")";
            continue;
        }
        auto& rows = found->second;
        for (const auto& key : section.keys) {
            const auto row = rows.find(key.key);
            if (row == rows.end()) {
                ADD_FAILURE() << doc << ": section " << section.name << " has no row for key " << key.key
                              << "; the reader takes it: " << said(key);
                continue;
            }
            const auto& cell = row->second.cells;
            const auto where = at(doc, row->second.line) + ": section " + section.name + ", key " + key.key;
            EXPECT_EQ(cell[1], key.type) << where << ": the type is '" << cell[1] << "' in the documentation, '"
                                         << key.type << "' in the reader";
            EXPECT_TRUE(same_default(cell[2], key.default_value))
                << where << ": the default is '" << cell[2] << "' in the documentation, '" << key.default_value
                << "' in the reader";
            EXPECT_TRUE(cell[3].find(key.range) != std::string::npos)
                << where << ": the range / values '" << cell[3] << "' do not state the reader's '" << key.range << "'";
            rows.erase(row);
        }
        for (const auto& [name, row] : rows) {
            ADD_FAILURE() << at(doc, row.line) << ": section " << section.name << " has a row for key " << name
                          << ", which the reader does not take there";
        }
    }
}

void expect_in_man_page(std::string_view man, const std::vector<SectionReference>& sections) {
    auto keys = man_keys(man, sections);
    for (const auto& section : sections) {
        const auto found = keys.find(section.name);
        if (found == keys.end()) {
            ADD_FAILURE() << man << ": no section " << section.name << " (a .SH or .SS heading naming it)";
            continue;
        }
        auto& introduced = found->second;
        for (const auto& key : section.keys) {
            if (introduced.erase(key.key) == 0) {
                ADD_FAILURE() << man << ": section " << section.name << " does not introduce key " << key.key
                              << " (.TP, then .B " << key.key << "); the reader takes it: " << said(key);
            }
        }
        for (const auto& [name, line] : introduced) {
            ADD_FAILURE() << at(man, line) << ": section " << section.name << " introduces key " << name
                          << ", which the reader does not take there";
        }
    }
}

void expect_reader_takes_every_key(const std::vector<SectionReference>& sections, const FileWith& with,
                                   const ReaderError& error) {
    for (const auto& section : sections) {
        const auto valid = error(with(section, "", ""));
        ASSERT_FALSE(valid) << section.name << ": the valid file was refused: " << *valid;
        for (const auto& key : section.keys) {
            const auto refused = error(with(section, key.key, "2024-01-01"));
            ASSERT_TRUE(refused) << section.name << ": key " << key.key << " = a date was accepted";
            EXPECT_EQ(refused->find("unknown key"), std::string::npos) << section.name << ": " << *refused;
            EXPECT_NE(refused->find(key.key), std::string::npos) << section.name << ": " << *refused;
        }
        const auto unknown = error(with(section, "no_such_key", "1"));
        ASSERT_TRUE(unknown) << section.name << ": a key no table lists was accepted";
        EXPECT_NE(unknown->find("unknown key 'no_such_key'"), std::string::npos) << section.name << ": " << *unknown;
    }
}

}  // namespace drivebus::docs
