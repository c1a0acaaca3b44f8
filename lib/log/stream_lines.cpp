// SPDX-License-Identifier: Apache-2.0
#include "log/stream_lines.hpp"

#include <algorithm>
#include <array>
#include <utility>

namespace drivebus::log {
namespace {

constexpr char kEscape = '\x1B';
// What iceoryx_hoofs/source/posix_wrapper/unix_domain_socket.cpp prints when a socket call
// fails in a way it did not expect.
constexpr std::string_view kSocketLogicError = "internal logic error in unix domain socket \"";
// A failed system call: "FILE:LINE { FUNCTION -> CALL }  :::  [ ERRNO ]  TEXT".
constexpr std::string_view kPosixCallMark = " }  :::  [ ";

bool is_digit(char c) {
    return c >= '0' && c <= '9';
}

// "2026-12-02 09:23:09.382 ": the shape of iceoryx's time stamp.
bool is_time_stamp(std::string_view s) {
    constexpr std::string_view kShape = "dddd-dd-dd dd:dd:dd.ddd ";
    if (s.size() < kShape.size()) {
        return false;
    }
    for (std::size_t i = 0; i < kShape.size(); ++i) {
        if (kShape[i] == 'd' ? !is_digit(s[i]) : s[i] != kShape[i]) {
            return false;
        }
    }
    return true;
}

// The first word of a line: a source file of iceoryx's ("./iceoryx_hoofs/source/...cpp").
bool starts_with_iceoryx_file(std::string_view line) {
    const auto word = line.substr(0, line.find_first_of(": "));
    return word.find("iceoryx_") != std::string_view::npos;
}

}  // namespace

std::string without_escapes(std::string_view text) {
    std::string out;
    out.reserve(text.size());
    for (std::size_t i = 0; i < text.size(); ++i) {
        if (text[i] != kEscape) {
            out += text[i];
            continue;
        }
        if (i + 1 < text.size() && text[i + 1] == '[') {
            // Parameters and intermediates, then one final byte in @..~.
            std::size_t j = i + 2;
            while (j < text.size() && (text[j] < '@' || text[j] > '~')) {
                ++j;
            }
            i = j;
        } else {
            ++i;  // ESC and the one character after it
        }
    }
    return out;
}

std::optional<IceoryxMessage> parse_iceoryx_message(std::string_view line) {
    if (!line.starts_with(kEscape)) {
        return std::nullopt;  // the logger always colours its line
    }
    const std::string plain = without_escapes(line);
    std::string_view rest = plain;
    if (!is_time_stamp(rest)) {
        return std::nullopt;
    }
    rest.remove_prefix(24);
    // iceoryx_hoofs/log/logcommon.hpp, LogLevelText.
    static constexpr std::array<std::pair<std::string_view, int>, 6> kLevels{{
        {"[ Fatal ]: ", 2},
        {"[ Error ]: ", 3},
        {"[Warning]: ", 4},
        {"[ Info  ]: ", 6},
        {"[ Debug ]: ", 7},
        {"[Verbose]: ", 7},
    }};
    for (const auto& [tag, priority] : kLevels) {
        if (rest.starts_with(tag)) {
            rest.remove_prefix(tag.size());
            while (!rest.empty() && (rest.back() == ' ' || rest.back() == '\r')) {
                rest.remove_suffix(1);
            }
            return IceoryxMessage{priority, std::string(rest)};
        }
    }
    return std::nullopt;
}

bool is_iceoryx_line(std::string_view line) {
    return parse_iceoryx_message(line).has_value() ||
           (starts_with_iceoryx_file(line) && line.find(kPosixCallMark) != std::string_view::npos) ||
           line.starts_with(kSocketLogicError);
}

bool may_become_iceoryx_line(std::string_view start) {
    return start.starts_with(kEscape) || starts_with_iceoryx_file(start) || kSocketLogicError.starts_with(start) ||
           start.starts_with(kSocketLogicError);
}

LineRouter::LineRouter(OnLine on_line, std::streambuf* through, Hold hold)
    : on_line_(std::move(on_line)), through_(through), hold_(std::move(hold)) {}

void LineRouter::take(std::string_view text) {
    bool taken = false;  // the line before, written in the same piece, was taken
    while (!text.empty()) {
        const auto newline = text.find('\n');
        if (newline == std::string_view::npos) {
            pending_ += text;
            return;
        }
        pending_ += text.substr(0, newline);
        text.remove_prefix(newline + 1);
        std::string line = std::move(pending_);
        pending_.clear();
        // iceoryx ends some messages with a newline of their own, before the logger's.
        if (line.empty() && taken) {
            taken = false;
            continue;
        }
        taken = on_line_(line);
        if (!taken && through_ != nullptr) {
            line += '\n';
            through_->sputn(line.data(), static_cast<std::streamsize>(line.size()));
        }
    }
}

LineRouter::int_type LineRouter::overflow(int_type c) {
    if (traits_type::eq_int_type(c, traits_type::eof())) {
        return traits_type::not_eof(c);
    }
    const char ch = traits_type::to_char_type(c);
    const std::lock_guard lock(mutex_);
    take(std::string_view(&ch, 1));
    return c;
}

std::streamsize LineRouter::xsputn(const char* s, std::streamsize n) {
    const std::lock_guard lock(mutex_);
    take(std::string_view(s, static_cast<std::size_t>(n)));
    return n;
}

int LineRouter::sync() {
    const std::lock_guard lock(mutex_);
    if (through_ == nullptr) {
        return 0;  // everything goes to on_line_, a line at a time
    }
    if (!pending_.empty() && !(hold_ && hold_(pending_))) {
        through_->sputn(pending_.data(), static_cast<std::streamsize>(pending_.size()));
        pending_.clear();
    }
    return through_->pubsync();
}

}  // namespace drivebus::log
