// SPDX-License-Identifier: Apache-2.0
// A file's keys, section by section, as a reader's tables (settings/keys.hpp) state them: what a
// program's documentation describes, and what a test checks it against.
#pragma once

#include <string>
#include <vector>

namespace drivebus::settings {

struct KeyReference {
    std::string key;
    std::string type;           // the TOML type as the documentation writes it: "array of 2 durations"
    std::string default_value;  // as the file would write it ("\"100ms\"", "64"), "required" or "none"
    std::string range;          // "1-99", "\"off\", \"on\"", or in words; empty: any value of the type
    std::string doc;            // one line
};

struct SectionReference {
    // As the documentation's headings name it: "[realtime]", "[[bus]]", "direction = \"kernel\""
    // (the keys of a [[bus]] only that direction takes).
    std::string name;
    std::vector<KeyReference> keys;  // in the order they are read
};

}  // namespace drivebus::settings
