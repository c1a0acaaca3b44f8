// A strict little JSON reader for the tests: enough to check drivebusctl's --json documents by
// key and value (and that they are JSON at all). Throws std::runtime_error on anything else.
#pragma once

#include <cstddef>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace drivebus::test::json {

struct Value {
    enum class Type { Null, Bool, Number, String, Array, Object } type = Type::Null;
    bool boolean = false;
    double number = 0;
    std::string text;
    std::vector<Value> items;
    std::map<std::string, Value> members;

    [[nodiscard]] bool has(const std::string& key) const { return type == Type::Object && members.contains(key); }
    [[nodiscard]] const Value& operator[](const std::string& key) const {
        if (!has(key)) {
            throw std::runtime_error("no key " + key);
        }
        return members.at(key);
    }
    [[nodiscard]] const Value& operator[](std::size_t i) const {
        if (type != Type::Array || i >= items.size()) {
            throw std::runtime_error("no item " + std::to_string(i));
        }
        return items[i];
    }
    [[nodiscard]] const std::string& str() const {
        if (type != Type::String) {
            throw std::runtime_error("not a string");
        }
        return text;
    }
    [[nodiscard]] double num() const {
        if (type != Type::Number) {
            throw std::runtime_error("not a number");
        }
        return number;
    }
    [[nodiscard]] bool is_null() const { return type == Type::Null; }
    // The item of an array whose `key` is the string `value`.
    [[nodiscard]] const Value& find(const std::string& key, const std::string& value) const {
        for (const auto& item : items) {
            if (item.has(key) && item[key].type == Type::String && item[key].text == value) {
                return item;
            }
        }
        throw std::runtime_error("no item with " + key + " = " + value);
    }
};

class Parser {
public:
    explicit Parser(std::string_view text) : text_(text) {}

    Value document() {
        auto v = value();
        space();
        if (pos_ != text_.size()) {
            fail("text after the document");
        }
        return v;
    }

private:
    [[noreturn]] void fail(const std::string& what) const {
        throw std::runtime_error("JSON: " + what + " at " + std::to_string(pos_));
    }
    void space() {
        while (pos_ < text_.size() && (text_[pos_] == ' ' || text_[pos_] == '\n' || text_[pos_] == '\t' ||
                                       text_[pos_] == '\r')) {
            ++pos_;
        }
    }
    bool take(char c) {
        space();
        if (pos_ < text_.size() && text_[pos_] == c) {
            ++pos_;
            return true;
        }
        return false;
    }
    void expect(char c) {
        if (!take(c)) {
            fail(std::string("expected ") + c);
        }
    }
    bool word(std::string_view w) {
        if (text_.substr(pos_, w.size()) == w) {
            pos_ += w.size();
            return true;
        }
        return false;
    }
    std::string string() {
        expect('"');
        std::string out;
        while (pos_ < text_.size() && text_[pos_] != '"') {
            char c = text_[pos_++];
            if (static_cast<unsigned char>(c) < 0x20) {
                fail("control character in a string");
            }
            if (c == '\\') {
                if (pos_ >= text_.size()) {
                    fail("escape at the end");
                }
                c = text_[pos_++];
                switch (c) {
                case 'n': out += '\n'; break;
                case 't': out += '\t'; break;
                case 'r': out += '\r'; break;
                case 'b': out += '\b'; break;
                case 'f': out += '\f'; break;
                case 'u': {
                    const auto code = std::stoul(std::string(text_.substr(pos_, 4)), nullptr, 16);
                    pos_ += 4;
                    if (code >= 0x80) {
                        fail("non-ASCII \\u escape (not used by drivebusctl)");
                    }
                    out += static_cast<char>(code);
                    break;
                }
                case '"':
                case '\\':
                case '/': out += c; break;
                default: fail("bad escape");
                }
            } else {
                out += c;
            }
        }
        expect('"');
        return out;
    }
    Value value() {
        space();
        Value v;
        if (pos_ >= text_.size()) {
            fail("end of text");
        }
        const char c = text_[pos_];
        if (c == '{') {
            v.type = Value::Type::Object;
            ++pos_;
            if (!take('}')) {
                do {
                    space();
                    auto key = string();
                    expect(':');
                    v.members[key] = value();
                } while (take(','));
                expect('}');
            }
        } else if (c == '[') {
            v.type = Value::Type::Array;
            ++pos_;
            if (!take(']')) {
                do {
                    v.items.push_back(value());
                } while (take(','));
                expect(']');
            }
        } else if (c == '"') {
            v.type = Value::Type::String;
            v.text = string();
        } else if (word("true")) {
            v.type = Value::Type::Bool;
            v.boolean = true;
        } else if (word("false")) {
            v.type = Value::Type::Bool;
        } else if (word("null")) {
            v.type = Value::Type::Null;
        } else {
            std::size_t used = 0;
            try {
                v.number = std::stod(std::string(text_.substr(pos_, 40)), &used);
            } catch (const std::exception&) {
                fail("not a value");
            }
            v.type = Value::Type::Number;
            pos_ += used;
        }
        return v;
    }

    std::string_view text_;
    std::size_t pos_ = 0;
};

inline Value parse(std::string_view text) {
    return Parser(text).document();
}

}  // namespace drivebus::test::json
