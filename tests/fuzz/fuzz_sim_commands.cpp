// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: the simulator's control-socket commands (sim::run_command), and the
// --fault / --option arguments, on arbitrary lines, against an Altivar 21 at address 1 and an
// Altivar 58 at address 2. Input: lines as the socket splits them ('\n', a trailing '\r'
// dropped); a line starting with "--fault " or "--option " goes to that argument's parser.
// Checks: every answer is one line starting "ok" or "error: "; a refused command changes no
// fault ("fault" is all or nothing); and after the commands, a request still gets a paced reply
// with a good CRC (or none, or a corrupted one, as the faults in force decide).
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "bus.hpp"
#include "commands.hpp"
#include "fuzz_support.hpp"
#include "rtu/codec.hpp"
#include "rtu/crc.hpp"

using namespace drivebus;
using namespace std::chrono_literals;
using fuzz::check;

namespace {

const rtu::CharacterTiming kTiming = rtu::character_timing({19200, 8, rtu::Parity::None, 1}).value();

void run_line(sim::Bus& bus, std::string_view line, rtu::Instant now) {
    if (line.starts_with("--fault ") || line.starts_with("--option ")) {
        const bool fault = line.starts_with("--fault ");
        const auto argument = line.substr(line.find(' ') + 1);
        const auto before = bus.faults().to_string();
        const auto ok = fault ? sim::apply_fault_argument(bus, argument) : sim::apply_option_argument(bus, argument);
        if (!ok) {
            check(!ok.error().empty(), "an argument refused without a reason");
            check(!fault || bus.faults().to_string() == before, "a refused --fault changed the faults");
        }
        return;
    }
    const auto before = bus.faults().to_string();
    const auto answer = sim::run_command(bus, line, now);
    check(answer.find('\n') == std::string::npos, "an answer of more than one line");
    check(answer.starts_with("ok") || answer.starts_with("error: "), "an answer neither ok nor error");
    if (answer.starts_with("error: ")) {
        check(bus.faults().to_string() == before, "a refused command changed the faults");
    }
}

// A read of FD01 from the Altivar 21 under whatever faults the commands left.
void check_still_answers(sim::Bus& bus, rtu::Instant now) {
    rtu::Frame frame;
    frame.adu = rtu::encode_request({1, rtu::ReadHoldingRegisters{0xFD01, 1}}).value();
    frame.first = now;
    frame.last = now + kTiming.character * static_cast<std::int64_t>(frame.adu.size() - 1);
    const auto plan = bus.on_frame(frame);
    rtu::Instant previous = frame.last;
    for (const auto& b : plan) {
        check(b.at > previous, "reply bytes out of order");
        previous = b.at;
    }
    const auto& faults = bus.faults().for_drive(1);
    if (!plan.empty() && faults.noise == 0 && faults.crc == 0.0) {
        rtu::Adu reply;
        for (const auto& b : plan) {
            check(reply.push_back(b.value), "a reply longer than an ADU");
        }
        check(rtu::crc_ok(reply.bytes()) && reply[0] == 1, "a reply with a bad CRC or address");
        check(plan.back().reply_end, "the reply's end is not marked");
    }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    static const auto atv21 = fuzz::shipped_profile("atv21");
    static const auto atv58 = fuzz::shipped_profile("atv58");
    sim::Bus bus({kTiming, 1ms, true, 1});
    bus.add(sim::make_drive(1, atv21));
    bus.add(sim::make_drive(2, atv58));

    rtu::Instant now{std::chrono::seconds(1000)};
    std::string_view input(reinterpret_cast<const char*>(data), size);
    while (!input.empty()) {
        const auto newline = input.find('\n');
        auto line = input.substr(0, newline);
        input = newline == std::string_view::npos ? std::string_view() : input.substr(newline + 1);
        if (line.ends_with('\r')) {
            line.remove_suffix(1);
        }
        now += 1ms;
        run_line(bus, line, now);
    }
    check_still_answers(bus, now + 1ms);
    return 0;
}
