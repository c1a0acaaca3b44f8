// SPDX-License-Identifier: Apache-2.0
// Plain-text tables: columns aligned, two spaces apart, the last column not padded.
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace drivebus::ctl {

using Row = std::vector<std::string>;

// The rows as lines, each prefixed with `indent` and ended with '\n'. Trailing spaces are cut.
[[nodiscard]] std::string render_table(const std::vector<Row>& rows, std::string_view indent = {});

// "key  value" lines with the keys aligned.
[[nodiscard]] std::string render_fields(const std::vector<std::pair<std::string, std::string>>& fields,
                                        std::string_view indent = {});

}  // namespace drivebus::ctl
