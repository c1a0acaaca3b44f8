// SPDX-License-Identifier: Apache-2.0
// drivebusctl's pure parts: values with units and scale, durations, register columns, exit
// codes and rejection hints. No daemon.
#include <gtest/gtest.h>

#include "format.hpp"

namespace drivebus::ctl {
namespace {

using namespace std::chrono_literals;

const Profile& atv21() {
    static const Profile p = load_profile(std::string(PROFILE_DIR) + "/atv21.toml").value();
    return p;
}

RegisterInfo signed_register() {
    RegisterInfo r;
    r.name = "T1";
    r.address = 0x100;
    r.unit = "°C";
    r.scale = 0.1;
    r.is_signed = true;
    return r;
}

TEST(CtlFormat, RawValuesInDecimalAndHex) {
    const auto* fa51 = atv21().find("FA51");
    EXPECT_EQ(parse_value("300", fa51).value(), 300);
    EXPECT_EQ(parse_value("0x12C", fa51).value(), 300);
    EXPECT_EQ(parse_value("0XFFFF", nullptr).value(), 0xFFFF);
    EXPECT_EQ(parse_value("65535", nullptr).value(), 65535);
    EXPECT_EQ(parse_value(" 7 ", nullptr).value(), 7);
}

TEST(CtlFormat, RawValuesOutside16BitsOrSignAreRefused) {
    EXPECT_FALSE(parse_value("65536", nullptr).has_value());
    EXPECT_FALSE(parse_value("-1", atv21().find("FA51")).has_value());
    EXPECT_NE(parse_value("-1", atv21().find("FA51")).error().find("not a signed register"), std::string::npos);
    EXPECT_FALSE(parse_value("0x10000", nullptr).has_value());
    EXPECT_FALSE(parse_value("", nullptr).has_value());
    EXPECT_FALSE(parse_value("abc", nullptr).has_value());
    EXPECT_FALSE(parse_value("12abc", nullptr).has_value());
}

TEST(CtlFormat, ValuesWithTheRegistersUnitGoThroughItsScale) {
    const auto* fa01 = atv21().find("FA01");  // Hz, 0.01
    EXPECT_EQ(parse_value("30Hz", fa01).value(), 3000);
    EXPECT_EQ(parse_value("30.5 Hz", fa01).value(), 3050);
    EXPECT_EQ(parse_value("30.5hz", fa01).value(), 3050);  // units match without case
    EXPECT_EQ(parse_value("0.01 Hz", fa01).value(), 1);
    EXPECT_EQ(parse_value("80 Hz", fa01).value(), 8000);
    EXPECT_EQ(parse_value("12.34Hz", fa01).value(), 1234);
    const auto* f803 = atv21().find("F803");  // s, scale 1
    EXPECT_EQ(parse_value("3s", f803).value(), 3);
}

TEST(CtlFormat, UnitMistakesSayWhatTheRegisterTakes) {
    const auto* fa01 = atv21().find("FA01");
    EXPECT_NE(parse_value("30s", fa01).error().find("FA01 is in Hz, not s"), std::string::npos);
    EXPECT_NE(parse_value("30.123 Hz", fa01).error().find("finer than"), std::string::npos);
    EXPECT_NE(parse_value("30.5", fa01).error().find("give it with its unit (30.5 Hz)"), std::string::npos);
    EXPECT_NE(parse_value("30 Hz", atv21().find("FA51")).error().find("FA51 has no unit"), std::string::npos);
    EXPECT_NE(parse_value("30 Hz", nullptr).error().find("raw value"), std::string::npos);
    EXPECT_NE(parse_value("1000 Hz", fa01).error().find("does not fit"), std::string::npos);
    EXPECT_FALSE(parse_value("0x10 Hz", fa01).has_value());
}

TEST(CtlFormat, SignedRegistersTakeNegativeValues) {
    const auto t = signed_register();
    EXPECT_EQ(parse_value("-1", &t).value(), 0xFFFF);
    EXPECT_EQ(parse_value("-12.5°C", &t).value(), static_cast<std::uint16_t>(-125 + 65536));
    EXPECT_FALSE(parse_value("40000", &t).has_value());
    EXPECT_EQ(format_engineering(t, 0xFF83), "-12.5 °C");
}

TEST(CtlFormat, UnitsGivenAsTheirOwnArgumentJoinTheNumber) {
    EXPECT_EQ(join_units({"30.5", "Hz"}), (std::vector<std::string>{"30.5 Hz"}));
    EXPECT_EQ(join_units({"1", "2", "0x3"}), (std::vector<std::string>{"1", "2", "0x3"}));
    EXPECT_EQ(join_units({"30", "Hz", "-5", "%"}), (std::vector<std::string>{"30 Hz", "-5 %"}));
    EXPECT_EQ(join_units({"Hz"}), (std::vector<std::string>{"Hz"}));
}

TEST(CtlFormat, Durations) {
    EXPECT_EQ(option_duration("500ms").value(), 500ms);
    EXPECT_EQ(option_duration("2s").value(), 2000ms);
    EXPECT_EQ(option_duration("1.5s").value(), 1500ms);
    EXPECT_EQ(option_duration("2min").value(), 120000ms);
    EXPECT_EQ(option_duration("1500us").value(), 2ms);  // rounded up
    EXPECT_EQ(option_duration(" 100 ms ").value(), 100ms);
    for (const auto* bad : {"", "s", "2x", "-1s", "0", "250", "0ms", "0x10ms", "1e9s", "fast", "25h"}) {
        EXPECT_FALSE(option_duration(bad).has_value()) << bad;
    }
    EXPECT_NE(option_duration("2x").error().find("'2x' is not a duration"), std::string::npos);
    // A bare number is refused, as everywhere: seconds or milliseconds?
    EXPECT_NE(option_duration("250").error().find("'250' has no unit"), std::string::npos);
}

TEST(CtlFormat, Ages) {
    EXPECT_EQ(format_age(35'400'000), "35 ms");
    EXPECT_EQ(format_age(1'250'000'000), "1.2 s");
    EXPECT_EQ(format_age(-5), "0 ms");
    EXPECT_EQ(format_age(180'000'000'000), "3 min");
    EXPECT_EQ(format_age(7'200'000'000'000), "2 h");
}

TEST(CtlFormat, RegisterColumnsShowNameHexRawValueAndTitle) {
    const auto& p = atv21();
    EXPECT_EQ(register_columns(0xFD00, 3000, p.find(std::uint16_t{0xFD00})),
              (std::vector<std::string>{"FD00", "0xFD00", "3000", "30.00 Hz", "Output frequency"}));
    EXPECT_EQ(register_columns(0xFA51, 300, p.find(std::uint16_t{0xFA51}))[3], "");
    EXPECT_EQ(register_columns(0x1234, 7, nullptr), (std::vector<std::string>{"-", "0x1234", "7", "", ""}));
    EXPECT_EQ(hex(0x01C2), "0x01C2");
}

TEST(CtlFormat, ScalesShowTheirDecimals) {
    EXPECT_EQ(decimals(0.01), 2);
    EXPECT_EQ(decimals(0.1), 1);
    EXPECT_EQ(decimals(1.0), 0);
    EXPECT_EQ(decimals(0.5), 1);
    EXPECT_EQ(decimals(10.0), 0);
    const auto* fe03 = atv21().find("FE03");
    EXPECT_DOUBLE_EQ(engineering(*fe03, 1234), 12.34);
    EXPECT_EQ(format_engineering(*fe03, 1234), "12.34 %");
}

TEST(CtlFormat, BitsSetAreNamedShort) {
    const auto* fd01 = atv21().find("FD01");
    EXPECT_EQ(set_bits(*fd01, 0x4404), (std::vector<std::string>{"2 Alarm", "10 Run/stop", "14 Ready"}));
    EXPECT_TRUE(set_bits(*fd01, 0).empty());
}

TEST(CtlFormat, ExitCodesByErrorKind) {
    EXPECT_EQ(exit_code(ErrorKind::Exception), 1);
    EXPECT_EQ(exit_code(ErrorKind::Timeout), 1);
    EXPECT_EQ(exit_code(ErrorKind::BadFrame), 1);
    EXPECT_EQ(exit_code(ErrorKind::InvalidArgument), 2);
    EXPECT_EQ(exit_code(ErrorKind::Rejected), 3);
    EXPECT_EQ(exit_code(ErrorKind::Unsupported), 3);
    EXPECT_EQ(exit_code(ErrorKind::NotPermitted), 4);
    for (const auto k : {ErrorKind::NotRunning, ErrorKind::NoSuchBus, ErrorKind::BusDown, ErrorKind::DaemonGone}) {
        EXPECT_EQ(exit_code(k), 5) << to_string(k);
    }
    EXPECT_EQ(exit_code(ErrorKind::QueueFull), 6);
    EXPECT_EQ(exit_code(ErrorKind::Withdrawn), 7);
    EXPECT_EQ(exit_code(ErrorKind::OutcomeUnknown), 8);
    EXPECT_EQ(exit_code(ErrorKind::NoReply), 8) << "answered neither the request nor its withdrawal: unknown";
    EXPECT_EQ(exit_code(ErrorKind::Expired), 9) << "not on the wire by its deadline: never sent";
    EXPECT_EQ(kind_name(ErrorKind::OutcomeUnknown), "outcome_unknown");
    EXPECT_EQ(kind_name(ErrorKind::NotPermitted), "not_permitted");
    EXPECT_EQ(kind_name(ErrorKind::Rejected), "rejected");
}

TEST(CtlFormat, RejectionHintsComeFromTheProfile) {
    Error e;
    e.kind = ErrorKind::Rejected;
    e.reason = shm::RejectReason::ValueOutOfRange;
    EXPECT_EQ(rejection_hint(e, &atv21(), "write", 0x0803, 1), "F803 takes 0..100 (0-100 s)");
    e.reason = shm::RejectReason::Quantity;
    EXPECT_EQ(rejection_hint(e, &atv21(), "read", 0xFD00, 2), "profile atv21 reads at most 1 register per request");
    e.reason = shm::RejectReason::ReadOnly;
    EXPECT_EQ(rejection_hint(e, &atv21(), "write", 0xFD00, 1), "FD00 can only be read");
    EXPECT_EQ(rejection_hint(e, &atv21(), "write", 0xFD00, 2), "");  // which of them, the hint cannot tell
    e.reason = shm::RejectReason::UnknownRegister;
    EXPECT_EQ(rejection_hint(e, &atv21(), "read", 0x1234, 1),
              "profile atv21 does not list it (its registers: atv21.toml)");
    e.kind = ErrorKind::Timeout;
    EXPECT_EQ(rejection_hint(e, &atv21(), "read", 0xFD00, 1), "");
    EXPECT_EQ(exception_name(2), "illegal data address");
    EXPECT_EQ(exception_name(6), "server device busy");
    EXPECT_EQ(exception_name(200), "undefined exception code");
}

}  // namespace
}  // namespace drivebus::ctl
