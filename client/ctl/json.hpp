// A small JSON value for drivebusctl --json: objects keep their keys in insertion order, and
// dump() writes one line.
#pragma once

#include <concepts>
#include <cstdint>
#include <string>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

namespace drivebus::ctl {

// `text` as a JSON string, quotes included: ", \ and control characters escaped.
[[nodiscard]] std::string json_quote(std::string_view text);

class Json {
public:
    using Array = std::vector<Json>;
    using Object = std::vector<std::pair<std::string, Json>>;

    Json() = default;  // null
    Json(std::nullptr_t) {}
    Json(bool value) : value_(value) {}
    template <std::integral T>
        requires(!std::same_as<T, bool> && !std::same_as<T, char>)
    Json(T value) {
        if constexpr (std::signed_integral<T>) {
            value_ = static_cast<std::int64_t>(value);
        } else {
            value_ = static_cast<std::uint64_t>(value);
        }
    }
    Json(double value) : value_(value) {}
    Json(std::string value) : value_(std::move(value)) {}
    Json(std::string_view value) : value_(std::string(value)) {}
    Json(const char* value) : value_(std::string(value)) {}

    [[nodiscard]] static Json object() { return Json(Object{}); }
    [[nodiscard]] static Json array() { return Json(Array{}); }

    // Adds a key to an object (replacing one of that name).
    Json& set(std::string_view key, Json value);
    // Appends to an array.
    Json& push(Json value);

    [[nodiscard]] std::string dump() const;

private:
    explicit Json(Object value) : value_(std::move(value)) {}
    explicit Json(Array value) : value_(std::move(value)) {}
    void dump(std::string& out) const;
    std::variant<std::nullptr_t, bool, std::int64_t, std::uint64_t, double, std::string, Array, Object> value_{
        nullptr};
};

}  // namespace drivebus::ctl
