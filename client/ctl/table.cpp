// SPDX-License-Identifier: Apache-2.0
#include "table.hpp"

#include <algorithm>

namespace drivebus::ctl {
namespace {

// Display width of UTF-8 text: code points, not bytes (no wide characters are used here).
std::size_t width(std::string_view text) {
    return static_cast<std::size_t>(
        std::ranges::count_if(text, [](char c) { return (static_cast<unsigned char>(c) & 0xC0U) != 0x80U; }));
}

}  // namespace

std::string render_table(const std::vector<Row>& rows, std::string_view indent) {
    std::vector<std::size_t> widths;
    for (const auto& row : rows) {
        if (widths.size() < row.size()) {
            widths.resize(row.size(), 0);
        }
        for (std::size_t i = 0; i < row.size(); ++i) {
            widths[i] = std::max(widths[i], width(row[i]));
        }
    }
    std::string out;
    for (const auto& row : rows) {
        std::string line(indent);
        for (std::size_t i = 0; i < row.size(); ++i) {
            line += row[i];
            if (i + 1 < row.size()) {
                line.append(widths[i] - width(row[i]) + 2, ' ');
            }
        }
        while (line.size() > indent.size() && line.back() == ' ') {
            line.pop_back();
        }
        out += line + '\n';
    }
    return out;
}

std::string render_fields(const std::vector<std::pair<std::string, std::string>>& fields, std::string_view indent) {
    std::vector<Row> rows;
    rows.reserve(fields.size());
    for (const auto& [key, value] : fields) {
        rows.push_back({key, value});
    }
    return render_table(rows, indent);
}

}  // namespace drivebus::ctl
