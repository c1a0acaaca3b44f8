// SPDX-License-Identifier: Apache-2.0
// A program's documentation against the key tables its reader reads by (settings/reference.hpp):
// the markdown page has a row for every key of each section, with the reader's type, default and
// range, and the man page introduces every key under its section; neither names a key the reader
// does not take there. Each finding is a GoogleTest failure that names the file and line.
#pragma once

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

}  // namespace drivebus::docs
