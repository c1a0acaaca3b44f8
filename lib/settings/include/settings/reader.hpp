// SPDX-License-Identifier: Apache-2.0
// Strict reading of TOML tables: typed getters whose errors name the file, the table and the
// key in one line, and a check that rejects unknown keys. Every file drivebus reads goes through
// it (profiles, drivebusd.toml, gateway.toml, mqtt.toml, and drivebusctl's reading of
// drivebusd.toml), so that one mistake is worded alike wherever it is made. The typed key tables
// on top of it are settings/keys.hpp.
#pragma once

#include <cstdint>
#include <expected>
#include <filesystem>
#include <initializer_list>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <toml++/toml.h>

namespace drivebus::settings {

// Keeps the first error of a parse: later ones often only follow from it.
class Errors {
public:
    explicit Errors(std::string_view source) : source_(source) {}

    void add(std::string_view where, std::string_view what);
    [[nodiscard]] bool any() const noexcept { return first_.has_value(); }
    // "file.toml: bus line1: baud 1234 is not a standard rate"; empty when there is none.
    [[nodiscard]] std::string message() const { return first_.value_or(""); }

private:
    std::string source_;
    std::optional<std::string> first_;
};

enum class Need : std::uint8_t { Optional, Required };

// One TOML table, named in errors as `where` ("drive", "register FA01"; empty for the root).
class Section {
public:
    Section(const toml::table& table, std::string where, Errors& errors)
        : table_(table), where_(std::move(where)), errors_(errors) {}

    // Fails on the first key not in `known`.
    void allow_only(std::initializer_list<std::string_view> known);

    std::optional<std::string> string(std::string_view key, Need need = Need::Optional);
    std::optional<std::int64_t> integer(std::string_view key, std::int64_t lo, std::int64_t hi,
                                        Need need = Need::Optional);
    std::optional<bool> boolean(std::string_view key);
    // An integer or a floating-point value.
    std::optional<double> number(std::string_view key);
    std::optional<std::vector<std::int64_t>> integers(std::string_view key, std::int64_t lo, std::int64_t hi);
    std::optional<std::vector<std::string>> strings(std::string_view key);
    const toml::table* table(std::string_view key, Need need = Need::Optional);
    // The tables of an array of tables ([[key]]); empty when the key is absent.
    std::vector<const toml::table*> tables(std::string_view key);
    // A table of strings keyed by integers ([register.bits], choices), keys checked against lo..hi.
    std::vector<std::pair<std::int64_t, std::string>> numbered_strings(std::string_view key, std::int64_t lo,
                                                                       std::int64_t hi);

    void fail(std::string_view what) { errors_.add(where_, what); }
    void rename(std::string where) { where_ = std::move(where); }
    [[nodiscard]] const std::string& where() const noexcept { return where_; }

private:
    const toml::node* get(std::string_view key, Need need);
    void wrong_type(std::string_view key, std::string_view wanted, const toml::node& node);
    void range_error(std::string_view what, std::int64_t value, std::int64_t lo, std::int64_t hi);

    const toml::table& table_;
    std::string where_;
    Errors& errors_;
};

// 'text' in quotes, anything unprintable escaped, so that an error stays on one line.
[[nodiscard]] std::string in_quotes(std::string_view text);
// "0xFA01".
[[nodiscard]] std::string hex4(std::uint32_t value);
// Shortest text that reads back as the same double.
[[nodiscard]] std::string number_text(double value);
// An integer written as a TOML key ("7", "-1", "0x1875"); nullopt if the key is not one.
[[nodiscard]] std::optional<std::int64_t> key_integer(std::string_view key);

// The file `text` holds, parsed; else its first syntax error in one line, named by `source`:
// "x.toml: line 3, column 7: expected '='".
[[nodiscard]] std::expected<toml::table, std::string> parse_toml(std::string_view text, std::string_view source);

// Reads a whole regular file of at most `max_size` bytes; the error is one line naming the file
// ("x.toml: 2000000 bytes is too large for a profile").
std::expected<std::string, std::string> read_small_file(const std::filesystem::path& file, std::uintmax_t max_size,
                                                        std::string_view what);

}  // namespace drivebus::settings
