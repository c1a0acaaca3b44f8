// SPDX-License-Identifier: Apache-2.0
// drivebusctl --json values: nlohmann-json's ordered_json (keys keep their insertion order),
// behind the few calls the commands use, and written on one line. A whole number stored as a
// double is written as an integer ("30", not "30.0"); NaN and infinities as null; invalid
// UTF-8 (a device name, say) replaced rather than thrown about.
#pragma once

#include <nlohmann/json.hpp>

#include <cmath>
#include <concepts>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>

namespace drivebus::ctl {

class Json {
public:
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
    Json(double value) {
        if (!std::isfinite(value)) {
            value_ = nullptr;
        } else if (std::trunc(value) == value && std::abs(value) < 9.0e15) {
            value_ = static_cast<std::int64_t>(value);
        } else {
            value_ = value;
        }
    }
    Json(std::string value) : value_(std::move(value)) {}
    Json(std::string_view value) : value_(std::string(value)) {}
    Json(const char* value) : value_(std::string(value)) {}

    [[nodiscard]] static Json object() { return Json(nlohmann::ordered_json::object()); }
    [[nodiscard]] static Json array() { return Json(nlohmann::ordered_json::array()); }

    // Adds a key to an object (replacing one of that name).
    Json& set(std::string_view key, Json value) {
        if (!value_.is_object()) {
            throw std::logic_error("Json::set on a value that is not an object");
        }
        value_[std::string(key)] = std::move(value.value_);
        return *this;
    }
    // Appends to an array.
    Json& push(Json value) {
        if (!value_.is_array()) {
            throw std::logic_error("Json::push on a value that is not an array");
        }
        value_.push_back(std::move(value.value_));
        return *this;
    }

    [[nodiscard]] std::string dump() const {
        return value_.dump(-1, ' ', false, nlohmann::ordered_json::error_handler_t::replace);
    }

private:
    explicit Json(nlohmann::ordered_json value) : value_(std::move(value)) {}
    nlohmann::ordered_json value_;
};

}  // namespace drivebus::ctl
