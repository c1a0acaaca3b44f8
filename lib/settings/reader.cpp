// SPDX-License-Identifier: Apache-2.0
// Strict typed access to TOML tables, with one-line errors.
#include "settings/reader.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <fstream>

namespace drivebus::settings {
namespace {

std::string_view type_name(toml::node_type type) noexcept {
    switch (type) {
    case toml::node_type::table: return "a table";
    case toml::node_type::array: return "an array";
    case toml::node_type::string: return "a string";
    case toml::node_type::integer: return "an integer";
    case toml::node_type::floating_point: return "a floating-point number";
    case toml::node_type::boolean: return "a boolean";
    case toml::node_type::date: return "a date";
    case toml::node_type::time: return "a time";
    case toml::node_type::date_time: return "a date-time";
    case toml::node_type::none: break;
    }
    return "nothing";
}

std::string element(std::string_view key, std::size_t index) {
    return std::string(key) + "[" + std::to_string(index) + "]";
}

}  // namespace

void Errors::add(std::string_view where, std::string_view what) {
    if (first_) {
        return;
    }
    std::string line = source_ + ": ";
    if (!where.empty()) {
        line.append(where).append(": ");
    }
    line.append(what);
    first_ = std::move(line);
}

void Section::allow_only(std::initializer_list<std::string_view> known) {
    for (const auto& entry : table_) {
        if (std::ranges::find(known, entry.first.str()) == known.end()) {
            fail("unknown key " + in_quotes(entry.first.str()));
            return;
        }
    }
}

const toml::node* Section::get(std::string_view key, Need need) {
    const toml::node* node = table_.get(key);
    if (node == nullptr && need == Need::Required) {
        fail("missing key " + in_quotes(key));
    }
    return node;
}

void Section::wrong_type(std::string_view key, std::string_view wanted, const toml::node& node) {
    fail(std::string(key) + " must be " + std::string(wanted) + ", not " + std::string(type_name(node.type())));
}

void Section::range_error(std::string_view what, std::int64_t value, std::int64_t lo, std::int64_t hi) {
    const bool below = value < lo;
    fail(std::string(what) + " " + std::to_string(value) + (below ? " is below " : " is above ") +
         std::to_string(below ? lo : hi));
}

std::optional<std::string> Section::string(std::string_view key, Need need) {
    const toml::node* node = get(key, need);
    if (node == nullptr) {
        return std::nullopt;
    }
    if (const auto* value = node->as_string()) {
        return value->get();
    }
    wrong_type(key, "a string", *node);
    return std::nullopt;
}

std::optional<std::int64_t> Section::integer(std::string_view key, std::int64_t lo, std::int64_t hi, Need need) {
    const toml::node* node = get(key, need);
    if (node == nullptr) {
        return std::nullopt;
    }
    const auto* value = node->as_integer();
    if (value == nullptr) {
        wrong_type(key, "an integer", *node);
        return std::nullopt;
    }
    if (value->get() < lo || value->get() > hi) {
        range_error(key, value->get(), lo, hi);
        return std::nullopt;
    }
    return value->get();
}

std::optional<bool> Section::boolean(std::string_view key) {
    const toml::node* node = get(key, Need::Optional);
    if (node == nullptr) {
        return std::nullopt;
    }
    if (const auto* value = node->as_boolean()) {
        return value->get();
    }
    wrong_type(key, "a boolean", *node);
    return std::nullopt;
}

std::optional<double> Section::number(std::string_view key) {
    const toml::node* node = get(key, Need::Optional);
    if (node == nullptr) {
        return std::nullopt;
    }
    if (const auto* value = node->as_floating_point()) {
        return value->get();
    }
    if (const auto* value = node->as_integer()) {
        return static_cast<double>(value->get());
    }
    wrong_type(key, "a number", *node);
    return std::nullopt;
}

std::optional<std::vector<std::int64_t>> Section::integers(std::string_view key, std::int64_t lo, std::int64_t hi) {
    const toml::node* node = get(key, Need::Optional);
    if (node == nullptr) {
        return std::nullopt;
    }
    const auto* array = node->as_array();
    if (array == nullptr) {
        wrong_type(key, "an array of integers", *node);
        return std::nullopt;
    }
    std::vector<std::int64_t> out;
    for (std::size_t i = 0; i < array->size(); ++i) {
        const auto* value = (*array)[i].as_integer();
        if (value == nullptr) {
            wrong_type(element(key, i), "an integer", (*array)[i]);
            return std::nullopt;
        }
        if (value->get() < lo || value->get() > hi) {
            range_error(element(key, i), value->get(), lo, hi);
            return std::nullopt;
        }
        out.push_back(value->get());
    }
    return out;
}

std::optional<std::vector<std::string>> Section::strings(std::string_view key) {
    const toml::node* node = get(key, Need::Optional);
    if (node == nullptr) {
        return std::nullopt;
    }
    const auto* array = node->as_array();
    if (array == nullptr) {
        wrong_type(key, "an array of strings", *node);
        return std::nullopt;
    }
    std::vector<std::string> out;
    for (std::size_t i = 0; i < array->size(); ++i) {
        const auto* value = (*array)[i].as_string();
        if (value == nullptr) {
            wrong_type(element(key, i), "a string", (*array)[i]);
            return std::nullopt;
        }
        out.push_back(value->get());
    }
    return out;
}

const toml::table* Section::table(std::string_view key, Need need) {
    const toml::node* node = get(key, need);
    if (node == nullptr) {
        return nullptr;
    }
    if (const auto* value = node->as_table()) {
        return value;
    }
    wrong_type(key, "a table", *node);
    return nullptr;
}

std::vector<const toml::table*> Section::tables(std::string_view key) {
    const toml::node* node = get(key, Need::Optional);
    if (node == nullptr) {
        return {};
    }
    const auto* array = node->as_array();
    if (array == nullptr) {
        wrong_type(key, "an array of tables ([[" + std::string(key) + "]])", *node);
        return {};
    }
    std::vector<const toml::table*> out;
    for (std::size_t i = 0; i < array->size(); ++i) {
        const auto* value = (*array)[i].as_table();
        if (value == nullptr) {
            wrong_type(element(key, i), "a table", (*array)[i]);
            return {};
        }
        out.push_back(value);
    }
    return out;
}

std::vector<std::pair<std::int64_t, std::string>> Section::numbered_strings(std::string_view key, std::int64_t lo,
                                                                            std::int64_t hi) {
    const toml::table* numbered = table(key);
    if (numbered == nullptr) {
        return {};
    }
    std::vector<std::pair<std::int64_t, std::string>> out;
    for (const auto& [name, node] : *numbered) {
        const auto number = key_integer(name.str());
        if (!number) {
            fail(std::string(key) + " key " + in_quotes(name.str()) + " is not a number");
            return {};
        }
        if (*number < lo || *number > hi) {
            range_error(std::string(key) + " key", *number, lo, hi);
            return {};
        }
        const auto* text = node.as_string();
        if (text == nullptr) {
            wrong_type(std::string(key) + "." + std::string(name.str()), "a string", node);
            return {};
        }
        out.emplace_back(*number, text->get());
    }
    return out;
}

std::string in_quotes(std::string_view text) {
    std::string out = "'";
    for (const char c : text) {
        const auto byte = static_cast<unsigned char>(c);
        if (byte < 0x20 || byte == 0x7F || c == '\'' || c == '\\') {
            out += hex4(byte).replace(0, 4, "\\x");  // "0x00NN" -> "\xNN"
        } else {
            out += c;
        }
    }
    out += '\'';
    return out;
}

std::string hex4(std::uint32_t value) {
    static constexpr std::array<char, 16> kDigits = {'0', '1', '2', '3', '4', '5', '6', '7',
                                                     '8', '9', 'A', 'B', 'C', 'D', 'E', 'F'};
    std::string out = "0x0000";
    for (std::size_t i = 0; i < 4; ++i) {
        out[5 - i] = kDigits[(value >> (4 * i)) & 0xFU];
    }
    return out;
}

std::string number_text(double value) {
    std::array<char, 32> buffer{};
    const auto result = std::to_chars(buffer.data(), buffer.data() + buffer.size(), value);
    return {buffer.data(), result.ptr};
}

std::optional<std::int64_t> key_integer(std::string_view key) {
    const bool negative = key.starts_with('-');
    if (negative) {
        key.remove_prefix(1);
    }
    int base = 10;
    if (key.starts_with("0x") || key.starts_with("0X")) {
        base = 16;
        key.remove_prefix(2);
    }
    std::int64_t value = 0;
    const auto result = std::from_chars(key.data(), key.data() + key.size(), value, base);
    if (key.empty() || result.ec != std::errc{} || result.ptr != key.data() + key.size() || value < 0) {
        return std::nullopt;
    }
    return negative ? -value : value;
}

std::expected<toml::table, std::string> parse_toml(std::string_view text, std::string_view source) {
    try {
        return toml::parse(text, source);
    } catch (const toml::parse_error& e) {
        std::string line = std::string(source) + ": line " + std::to_string(e.source().begin.line) + ", column " +
                           std::to_string(e.source().begin.column) + ": ";
        for (const char c : e.description()) {
            line += (c == '\n' || c == '\r') ? ' ' : c;
        }
        return std::unexpected(std::move(line));
    }
}

std::expected<std::string, std::string> read_small_file(const std::filesystem::path& file, std::uintmax_t max_size,
                                                        std::string_view what) {
    namespace fs = std::filesystem;
    const auto name = file.string();
    std::error_code ec;
    const auto status = fs::status(file, ec);
    if (ec) {
        return std::unexpected(name + ": " + ec.message());
    }
    if (!fs::is_regular_file(status)) {
        return std::unexpected(name + ": not a regular file");
    }
    const auto size = fs::file_size(file, ec);
    if (ec) {
        return std::unexpected(name + ": " + ec.message());
    }
    if (size > max_size) {
        return std::unexpected(name + ": " + std::to_string(size) + " bytes is too large for " + std::string(what));
    }
    std::string text(static_cast<std::size_t>(size), '\0');
    std::ifstream in(file, std::ios::binary);
    if (!in.read(text.data(), static_cast<std::streamsize>(text.size()))) {
        return std::unexpected(name + ": cannot be read");
    }
    return text;
}

}  // namespace drivebus::settings
