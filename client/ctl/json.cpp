#include "json.hpp"

#include <fmt/format.h>

#include <cmath>
#include <stdexcept>

namespace drivebus::ctl {

std::string json_quote(std::string_view text) {
    std::string out;
    out.reserve(text.size() + 2);
    out += '"';
    for (const char c : text) {
        switch (c) {
        case '"': out += "\\\""; break;
        case '\\': out += "\\\\"; break;
        case '\n': out += "\\n"; break;
        case '\r': out += "\\r"; break;
        case '\t': out += "\\t"; break;
        case '\b': out += "\\b"; break;
        case '\f': out += "\\f"; break;
        default:
            if (static_cast<unsigned char>(c) < 0x20 || c == '\x7f') {
                out += fmt::format("\\u{:04x}", static_cast<unsigned>(static_cast<unsigned char>(c)));
            } else {
                out += c;
            }
        }
    }
    out += '"';
    return out;
}

Json& Json::set(std::string_view key, Json value) {
    auto* object = std::get_if<Object>(&value_);
    if (object == nullptr) {
        throw std::logic_error("Json::set on a value that is not an object");
    }
    for (auto& [k, v] : *object) {
        if (k == key) {
            v = std::move(value);
            return *this;
        }
    }
    object->emplace_back(std::string(key), std::move(value));
    return *this;
}

Json& Json::push(Json value) {
    auto* array = std::get_if<Array>(&value_);
    if (array == nullptr) {
        throw std::logic_error("Json::push on a value that is not an array");
    }
    array->push_back(std::move(value));
    return *this;
}

std::string Json::dump() const {
    std::string out;
    dump(out);
    return out;
}

void Json::dump(std::string& out) const {
    std::visit(
        [&](const auto& v) {
            using T = std::decay_t<decltype(v)>;
            if constexpr (std::is_same_v<T, std::nullptr_t>) {
                out += "null";
            } else if constexpr (std::is_same_v<T, bool>) {
                out += v ? "true" : "false";
            } else if constexpr (std::is_same_v<T, std::int64_t> || std::is_same_v<T, std::uint64_t>) {
                out += std::to_string(v);
            } else if constexpr (std::is_same_v<T, double>) {
                out += std::isfinite(v) ? fmt::format("{}", v) : std::string("null");
            } else if constexpr (std::is_same_v<T, std::string>) {
                out += json_quote(v);
            } else if constexpr (std::is_same_v<T, Array>) {
                out += '[';
                for (std::size_t i = 0; i < v.size(); ++i) {
                    if (i > 0) {
                        out += ',';
                    }
                    v[i].dump(out);
                }
                out += ']';
            } else {
                out += '{';
                for (std::size_t i = 0; i < v.size(); ++i) {
                    if (i > 0) {
                        out += ',';
                    }
                    out += json_quote(v[i].first);
                    out += ':';
                    v[i].second.dump(out);
                }
                out += '}';
            }
        },
        value_);
}

}  // namespace drivebus::ctl
