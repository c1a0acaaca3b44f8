// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: the echo filter (master::EchoFilter) on arbitrary requests and reads.
// Input: [setting] then records. [0][length][bytes...] sends a request (expect()); [1][k][length]
// [bytes...] is one read: the next k bytes of the true echo (so that matching echoes are
// common), then the given bytes. Checks, against a model of what was heard since the request:
// no byte is lost or counted twice (the echo the filter took is a prefix of the request, and
// whatever it did not take, or gives back through replay(), is what followed on the line), a
// complete echo is Matched only when it equals the request, a mismatch stops at the first
// differing byte, and auto mode decides once, for good.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "fuzz_support.hpp"
#include "master/echo_filter.hpp"

using namespace drivebus;
using fuzz::check;
using master::EchoFilter;
using master::EchoSetting;

namespace {

struct Model {
    rtu::Adu sent;
    std::vector<std::uint8_t> heard;  // every byte read since the request
    std::size_t taken = 0;            // bytes the filter consumed since the request
    bool waiting = false;             // the filter said Pending after expect()
};

bool prefix_of(std::span<const std::uint8_t> part, std::span<const std::uint8_t> whole) {
    return part.size() <= whole.size() && std::ranges::equal(part, whole.first(part.size()));
}

void check_read(EchoFilter& filter, Model& m, std::span<const std::uint8_t> read) {
    const auto before = filter.status();
    const auto setting = filter.setting();
    const std::size_t used = filter.consume(read);
    check(used <= read.size(), "consumed more than was read");
    if (before != EchoFilter::Status::Pending) {
        check(used == 0 && filter.status() == before, "a filter that waits for nothing took bytes");
        return;
    }
    const std::size_t start = m.heard.size();
    m.heard.insert(m.heard.end(), read.begin(), read.end());
    const auto sent = m.sent.bytes();
    switch (filter.status()) {
    case EchoFilter::Status::Pending:
        check(used == read.size(), "still pending but left bytes");
        m.taken += used;
        check(m.taken < sent.size() && prefix_of(std::span(m.heard).first(m.taken), sent),
              "pending on bytes that are not the request's");
        break;
    case EchoFilter::Status::Matched:
        m.taken += used;
        check(m.taken == sent.size() && prefix_of(std::span(m.heard).first(m.taken), sent),
              "matched an echo that is not the request");
        check(setting != EchoSetting::Auto || filter.setting() == EchoSetting::On, "auto did not decide on");
        break;
    case EchoFilter::Status::Mismatch: {
        check(setting == EchoSetting::On && used >= 1, "a mismatch outside on mode");
        m.taken += used;
        const auto echo = std::span(m.heard).first(m.taken);
        check(m.taken <= sent.size() && prefix_of(echo.first(m.taken - 1), sent) && echo.back() != sent[m.taken - 1],
              "a mismatch not at the first differing byte");
        break;
    }
    case EchoFilter::Status::NoEcho: {
        check(setting == EchoSetting::Auto && filter.setting() == EchoSetting::Off && used == 0,
              "no echo outside auto mode, or undecided");
        // The bytes held from earlier reads come back, in order, before this read's.
        check(std::ranges::equal(filter.replay(), std::span(m.heard).first(start)), "replay is not what was held");
        check(m.taken == start && prefix_of(filter.replay(), sent), "held bytes that were not the echo");
        const auto rest = std::span(m.heard).subspan(start);
        const std::size_t n = std::min(rest.size(), sent.size() - start);
        check(!std::ranges::equal(rest.first(n), sent.subspan(start, n)), "no echo, yet this read was the echo");
        break;
    }
    case EchoFilter::Status::Idle: fuzz::fail("idle after pending");
    }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size < 1) {
        return 0;
    }
    EchoFilter filter(static_cast<EchoSetting>(data[0] % 3));
    Model m;
    std::size_t pos = 1;
    while (pos + 2 <= size) {
        const std::uint8_t op = data[pos] % 2;
        if (op == 0) {
            const std::size_t length = std::min<std::size_t>(data[pos + 1], size - pos - 2);
            m = Model{};
            (void)m.sent.append({data + pos + 2, length});
            pos += 2 + length;
            const auto setting = filter.setting();
            filter.expect(m.sent);
            const bool undecidable = setting == EchoSetting::Auto && m.sent.size() > 1 && m.sent[1] == 0x06;
            const bool waits = setting != EchoSetting::Off && !undecidable;
            check(filter.status() == (waits ? EchoFilter::Status::Pending : EchoFilter::Status::Idle),
                  "expect() did not wait for exactly the echoes it should");
            check(filter.replay().empty(), "replay left from the last request");
            continue;
        }
        if (pos + 3 > size) {
            break;
        }
        const std::size_t k = data[pos + 1];
        const std::size_t length = std::min<std::size_t>(data[pos + 2], size - pos - 3);
        std::vector<std::uint8_t> read;
        const auto sent = m.sent.bytes();
        for (std::size_t i = m.heard.size(); i < sent.size() && read.size() < k; ++i) {
            read.push_back(sent[i]);
        }
        read.insert(read.end(), data + pos + 3, data + pos + 3 + length);
        pos += 3 + length;
        check_read(filter, m, read);
    }
    return 0;
}
