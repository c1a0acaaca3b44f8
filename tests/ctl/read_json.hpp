// SPDX-License-Identifier: Apache-2.0
// The tests read drivebusctl's --json documents with nlohmann-json, through the few calls they
// use: a key or an item (throwing when absent), a string, a number, the item of an array with
// a given key. Anything that is not JSON throws at parse().
#pragma once

#include <nlohmann/json.hpp>

#include <cstddef>
#include <stdexcept>
#include <string>
#include <vector>

namespace drivebus::test::json {

struct Value {
    enum class Type { Null, Bool, Number, String, Array, Object };
    Type type = Type::Null;
    bool boolean = false;
    std::vector<Value> items;  // an array's
    nlohmann::json doc;

    Value() = default;
    explicit Value(nlohmann::json j) : doc(std::move(j)) {
        if (doc.is_boolean()) {
            type = Type::Bool;
            boolean = doc.get<bool>();
        } else if (doc.is_number()) {
            type = Type::Number;
        } else if (doc.is_string()) {
            type = Type::String;
        } else if (doc.is_array()) {
            type = Type::Array;
            for (const auto& item : doc) {
                items.emplace_back(item);
            }
        } else if (doc.is_object()) {
            type = Type::Object;
        }
    }

    [[nodiscard]] bool has(const std::string& key) const { return doc.is_object() && doc.contains(key); }
    [[nodiscard]] Value operator[](const std::string& key) const {
        if (!has(key)) {
            throw std::runtime_error("no key " + key);
        }
        return Value(doc.at(key));
    }
    [[nodiscard]] Value operator[](std::size_t i) const {
        if (!doc.is_array() || i >= doc.size()) {
            throw std::runtime_error("no item " + std::to_string(i));
        }
        return Value(doc.at(i));
    }
    [[nodiscard]] std::string str() const {
        if (!doc.is_string()) {
            throw std::runtime_error("not a string: " + doc.dump());
        }
        return doc.get<std::string>();
    }
    [[nodiscard]] double num() const {
        if (!doc.is_number()) {
            throw std::runtime_error("not a number: " + doc.dump());
        }
        return doc.get<double>();
    }
    [[nodiscard]] bool is_null() const { return doc.is_null(); }
    // The item of an array whose `key` is the string `value`.
    [[nodiscard]] Value find(const std::string& key, const std::string& value) const {
        for (const auto& item : items) {
            if (item.has(key) && item.doc.at(key).is_string() && item.doc.at(key).get<std::string>() == value) {
                return item;
            }
        }
        throw std::runtime_error("no item with " + key + " = " + value);
    }
};

[[nodiscard]] inline Value parse(const std::string& text) {
    return Value(nlohmann::json::parse(text));
}

}  // namespace drivebus::test::json
