// SPDX-License-Identifier: Apache-2.0
// The keys of drivebusd's configuration file, section by section, as the reader's own tables
// state them: what docs/configuration.md and drivebusd.toml(5) describe, and what a test checks
// them against.
#pragma once

#include <string>
#include <vector>

namespace drivebus::config {

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

// Every section of the file, in the order they are read.
[[nodiscard]] std::vector<SectionReference> reference();

}  // namespace drivebus::config
