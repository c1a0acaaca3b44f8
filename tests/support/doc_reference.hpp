// SPDX-License-Identifier: Apache-2.0
// A program's documentation against the key tables its reader reads by (settings/reference.hpp):
// the markdown page has a row for every key of each section, with the reader's type, default and
// range, and the man page introduces every key under its section; neither names a key the reader
// does not take there. And the reader against its tables: it takes every key they list and no
// other. Each finding is a GoogleTest failure that names the file and line, or the key.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "settings/reference.hpp"

namespace drivebus::docs {

// Every section has keys, each once, each with a type, a default and a line of doc.
void expect_well_formed(const std::vector<settings::SectionReference>& sections);

// `doc` (relative to the source tree): under a heading whose first code span names a section
// ("## `[[bus]]` (at least one)"), the table "| key | type | default | range / values | meaning |"
// with a row per key.
void expect_documented(std::string_view doc, const std::vector<settings::SectionReference>& sections);

// `man` (relative to the source tree): under a .SH or .SS heading naming a section, each key
// introduced by ".TP" and ".B key".
void expect_in_man_page(std::string_view man, const std::vector<settings::SectionReference>& sections);

// A valid file with `key = value` in `section` (in place of any line of that key); with no key,
// the valid file as it is.
using FileWith = std::function<std::string(const settings::SectionReference& section, const std::string& key,
                                           const std::string& value)>;
// The reader's error for a file, nothing when it takes it.
using ReaderError = std::function<std::optional<std::string>(const std::string& text)>;

// Each key of each section given a value of no key's type (a date): the reader refuses it with
// an error that names the key and is never "unknown key"; a key no table lists is refused as
// "unknown key 'no_such_key'".
void expect_reader_takes_every_key(const std::vector<settings::SectionReference>& sections, const FileWith& with,
                                   const ReaderError& error);

}  // namespace drivebus::docs
