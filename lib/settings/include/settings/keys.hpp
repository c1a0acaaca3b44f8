// SPDX-License-Identifier: Apache-2.0
// Typed key tables: a section of a file is read by a table of its keys, each with its TOML type,
// its range, the field it fills and one line of doc. A section's table reads it and lists its
// only keys (anything else is an unknown key); described() shows the same table, which is what
// a program's documentation is tested against. Rules that span keys stay as code next to each
// table. drivebusd, drivebus-gateway, drivebus-mqtt and drivebusctl read their files by them.
//
// Defaults live in the structs' default member initialisers and nowhere else (drivebusd's
// BusPlan and DrivePlan are also built directly, by tests and benchmarks, and need them there):
// a table shows what a default-constructed struct holds rather than repeating the number, and a
// reader leaves a field alone when its key is absent.
#pragma once

#include <algorithm>
#include <array>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <initializer_list>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "settings/reader.hpp"
#include "settings/reference.hpp"

namespace drivebus::settings {

// Every duration a file holds, to the nanosecond.
using Duration = std::chrono::nanoseconds;

// "none, even, odd".
[[nodiscard]] std::string listed(std::span<const std::string_view> names);
// "100ms", "1s", "1500us": the largest unit that keeps the number whole.
[[nodiscard]] std::string duration_text(Duration duration);
// Checks a duration written as `text` under `key` against lo..hi.
std::optional<Duration> checked_duration(Section& s, std::string_view key, std::string_view text, Duration lo,
                                         Duration hi);
// Reads a duration key of `table` (a string such as "100ms") and checks it against lo..hi.
std::optional<Duration> duration(Section& s, const toml::table& table, std::string_view key, Duration lo, Duration hi,
                                 Need need = Need::Optional);
// Reads a string key that must be one of `names`; its index in `names`.
std::optional<std::size_t> choice(Section& s, std::string_view key, std::span<const std::string_view> names);

// How a range is stated.
enum class Form : std::uint8_t { None, Words, Integers, Durations, Names };

// What a key accepts: its reader checks it, reference() states it.
struct Range {
    Form form = Form::None;
    std::string_view words;  // a rule numbers cannot state ("absolute path"), or what leads them ("each")
    std::int64_t lo = 0;
    std::int64_t hi = 0;
    Duration shortest{};
    Duration longest{};
    std::span<const std::string_view> names;  // an enum field takes the index: the enum's order
};

constexpr Range words(std::string_view text) {
    return {Form::Words, text, 0, 0, {}, {}, {}};
}
constexpr Range integers(std::int64_t lo, std::int64_t hi, std::string_view lead = {}) {
    return {Form::Integers, lead, lo, hi, {}, {}, {}};
}
constexpr Range durations(Duration shortest, Duration longest, std::string_view lead = {}) {
    return {Form::Durations, lead, 0, 0, shortest, longest, {}};
}
constexpr Range names(std::span<const std::string_view> values) {
    return {Form::Names, {}, 0, 0, {}, {}, values};
}

// Whether `values`, the enumerators `names` name, in the same order, are 0, 1, 2...: a choice()
// key reads an enum field by its index in `names`.
template <typename E, std::size_t N>
constexpr bool in_enum_order(const std::array<std::string_view, N>& /*names*/, std::initializer_list<E> values) {
    std::size_t index = 0;
    return values.size() == N &&
           std::ranges::all_of(values, [&](E value) { return static_cast<std::size_t>(value) == index++; });
}

template <typename T>
struct Key {
    // Reads the key of `table` into `out`, checked against `key.range`; absent, the field keeps
    // its default. Called for every key of the table, present or not.
    using Reader = void (*)(Section& s, const toml::table& table, const Key& key, T& out);
    // The default, as the file would write it; none for a required key.
    using Shown = std::string (*)(const Key& key);

    std::string_view name;
    std::string_view type;  // as the documentation writes it
    Need need = Need::Optional;
    Range range;
    Reader read = nullptr;
    Shown shown = nullptr;
    std::string_view doc;
};

template <typename T, std::size_t N>
using Table = std::array<Key<T>, N>;

// `object.*a.*b`: the field a path of member pointers leads to.
template <auto First, auto... Rest, typename T>
constexpr auto& field(T& object) {
    if constexpr (sizeof...(Rest) == 0) {
        return object.*First;
    } else {
        return field<Rest...>(object.*First);
    }
}

template <typename V>
inline constexpr bool kOptional = false;
template <typename V>
inline constexpr bool kOptional<std::optional<V>> = true;

// A std::chrono::duration of any unit: a program may keep a duration in milliseconds.
template <typename V>
inline constexpr bool kChrono = false;
template <typename Rep, typename Period>
inline constexpr bool kChrono<std::chrono::duration<Rep, Period>> = true;

// "\"100ms\"", "64", "true", "none" for an empty optional, list or path.
template <typename V>
std::string shown_value(const V& value, std::span<const std::string_view> names) {
    const auto quoted = [](std::string_view text) { return "\"" + std::string(text) + "\""; };
    if constexpr (std::is_same_v<V, bool>) {
        return value ? "true" : "false";
    } else if constexpr (std::is_enum_v<V>) {
        const auto index = static_cast<std::size_t>(value);
        return index < names.size() ? quoted(names[index]) : "?";
    } else if constexpr (std::is_integral_v<V>) {
        return std::to_string(+value);
    } else if constexpr (std::is_floating_point_v<V>) {
        return number_text(value);
    } else if constexpr (kChrono<V>) {
        return quoted(duration_text(std::chrono::duration_cast<Duration>(value)));
    } else if constexpr (std::is_same_v<V, std::string>) {
        return quoted(value);
    } else if constexpr (std::is_same_v<V, std::filesystem::path>) {
        return value.empty() ? "none" : quoted(value.string());
    } else if constexpr (kOptional<V>) {
        return value ? shown_value(*value, names) : "none";
    } else {
        std::string out;
        for (const auto& element : value) {
            out.append(out.empty() ? "[" : ", ").append(shown_value(element, names));
        }
        return out.empty() ? "none" : out + "]";
    }
}

// The factories of a table's keys for sections read into a T. A key named by a path of member
// pointers (`&BusConfig::kernel, &KernelRs485Options::rts_on_send`) fills that field and shows
// its default-constructed value.
template <typename T>
struct Keys {
    using K = Key<T>;

    template <auto... Path>
    static constexpr K integer(std::string_view name, std::int64_t lo, std::int64_t hi, std::string_view doc,
                               Need need = Need::Optional) {
        return {name, "integer", need, integers(lo, hi), &read_integer<Path...>, &shown<Path...>, doc};
    }
    template <auto... Path>
    static constexpr K boolean(std::string_view name, std::string_view doc) {
        return {name, "boolean", Need::Optional, {}, &read_boolean<Path...>, &shown<Path...>, doc};
    }
    template <auto... Path>
    static constexpr K duration(std::string_view name, Duration shortest, Duration longest, std::string_view doc,
                                Need need = Need::Optional) {
        return {name, "duration", need, durations(shortest, longest), &read_duration<Path...>, &shown<Path...>, doc};
    }
    // A string, into a std::string field; `range` states what it may be ("a bus name").
    template <auto... Path>
    static constexpr K text(std::string_view name, Range range, std::string_view doc, Need need = Need::Optional) {
        return {name, "string", need, range, &read_text<Path...>, &shown<Path...>, doc};
    }
    // A file's path, into a std::filesystem::path field; `range` states what it may be.
    template <auto... Path>
    static constexpr K path(std::string_view name, Range range, std::string_view doc, Need need = Need::Optional) {
        return {name, "string", need, range, &read_path<Path...>, &shown<Path...>, doc};
    }
    // A string among `values`, into an enum field whose enumerators are in their order.
    template <auto... Path>
    static constexpr K choice(std::string_view name, std::span<const std::string_view> values, std::string_view doc) {
        return {name, "string", Need::Optional, names(values), &read_choice<Path...>, &shown<Path...>, doc};
    }
    // A key whose reading needs more than a type and a range: its own reader.
    static constexpr K custom(std::string_view name, std::string_view type, Need need, Range range,
                              typename K::Reader read, typename K::Shown shown, std::string_view doc) {
        return {name, type, need, range, read, shown, doc};
    }

    // The default of the field at Path, from a default-constructed T.
    template <auto... Path>
    static std::string shown(const K& key) {
        const T object{};
        return shown_value(field<Path...>(object), key.range.names);
    }

    // The readers of the factories above, for a custom key that only shows its default otherwise.
    template <auto... Path>
    static void read_integer(Section& s, const toml::table& /*table*/, const K& key, T& out) {
        auto& value = field<Path...>(out);
        if (const auto read = s.integer(key.name, key.range.lo, key.range.hi, key.need)) {
            value = static_cast<std::remove_cvref_t<decltype(value)>>(*read);
        }
    }
    template <auto... Path>
    static void read_boolean(Section& s, const toml::table& /*table*/, const K& key, T& out) {
        if (const auto read = s.boolean(key.name)) {
            field<Path...>(out) = *read;
        }
    }
    // Into a Duration (or an optional one), or into a coarser unit when the value is a whole
    // number of it: a gateway that counts in milliseconds refuses "1500us" rather than cut it.
    template <auto... Path>
    static void read_duration(Section& s, const toml::table& table, const K& key, T& out) {
        const auto& range = key.range;
        const auto read = settings::duration(s, table, key.name, range.shortest, range.longest, key.need);
        if (!read) {
            return;
        }
        auto& value = field<Path...>(out);
        using V = std::remove_cvref_t<decltype(value)>;
        if constexpr (std::is_assignable_v<V&, Duration>) {
            value = *read;
        } else {
            const auto whole = std::chrono::duration_cast<V>(*read);
            if (whole != *read) {
                s.fail(std::string(key.name) + " " + duration_text(*read) + " is not a whole number of " +
                       duration_text(std::chrono::duration_cast<Duration>(V(1))).substr(1));
                return;
            }
            value = whole;
        }
    }
    template <auto... Path>
    static void read_path(Section& s, const toml::table& /*table*/, const K& key, T& out) {
        if (auto read = s.string(key.name, key.need)) {
            if (read->empty()) {
                s.fail(std::string(key.name) + " is empty");
                return;
            }
            field<Path...>(out) = std::move(*read);
        }
    }
    template <auto... Path>
    static void read_text(Section& s, const toml::table& /*table*/, const K& key, T& out) {
        if (auto read = s.string(key.name, key.need)) {
            field<Path...>(out) = std::move(*read);
        }
    }
    template <auto... Path>
    static void read_choice(Section& s, const toml::table& /*table*/, const K& key, T& out) {
        auto& value = field<Path...>(out);
        if (const auto index = settings::choice(s, key.name, key.range.names)) {
            value = static_cast<std::remove_cvref_t<decltype(value)>>(*index);
        }
    }
};

// Every key of the table, in its order.
template <typename T, std::size_t N>
void read_keys(Section& s, const toml::table& table, const Table<T, N>& keys, T& out) {
    for (const auto& key : keys) {
        key.read(s, table, key, out);
    }
}

// Whether one of the tables lists `name`.
template <typename... Tables>
[[nodiscard]] bool listed_in(std::string_view name, const Tables&... tables) {
    return (std::ranges::any_of(tables, [&](const auto& key) { return key.name == name; }) || ...);
}

// Fails on the first key of `table` that neither the tables nor `sections` (the arrays of tables
// it holds, "drive") list.
template <typename... Tables>
void allow_only(Section& s, const toml::table& table, std::initializer_list<std::string_view> sections,
                const Tables&... tables) {
    for (const auto& [name, node] : table) {
        if (!listed_in(name.str(), tables...) && std::ranges::find(sections, name.str()) == sections.end()) {
            s.fail("unknown key " + in_quotes(name.str()));
            return;
        }
    }
}

// "1-99", "0-1ms", "\"off\", \"on\"", "each 0-1023".
[[nodiscard]] std::string range_text(const Range& range);

// The section as reference() shows it.
template <typename T, std::size_t N>
SectionReference described(std::string_view section, const Table<T, N>& keys) {
    SectionReference out{std::string(section), {}};
    for (const auto& key : keys) {
        out.keys.push_back({std::string(key.name), std::string(key.type),
                            key.need == Need::Required ? "required" : key.shown(key), range_text(key.range),
                            std::string(key.doc)});
    }
    return out;
}

}  // namespace drivebus::settings
