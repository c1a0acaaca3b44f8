// SPDX-License-Identifier: Apache-2.0
// The keys of drivebusd's configuration file, section by section, as the reader's own tables
// state them: what docs/configuration.md and drivebusd.toml(5) describe, and what a test checks
// them against.
#pragma once

#include <vector>

#include "settings/reference.hpp"

namespace drivebus::config {

using settings::KeyReference;
using settings::SectionReference;

// Every section of the file, in the order they are read.
[[nodiscard]] std::vector<SectionReference> reference();

}  // namespace drivebus::config
