// SPDX-License-Identifier: Apache-2.0
// The gateway's pure parts: MBAP framing, request PDUs, networks, configuration, routing.
#include <gtest/gtest.h>

#include <netinet/in.h>

#include <chrono>
#include <cstring>

#include "gateway/config.hpp"
#include "gateway/mbap.hpp"
#include "gateway/network.hpp"
#include "gateway/pdu.hpp"
#include "gateway/route.hpp"

using namespace drivebus;
using namespace drivebus::gateway;
using Bytes = std::vector<std::uint8_t>;

namespace {

// Modbus Application Protocol v1.1b3, 6.3: read 3 registers from 0x006B; with an MBAP header.
const Bytes kRead = {0x00, 0x01, 0x00, 0x00, 0x00, 0x06, 0x11, 0x03, 0x00, 0x6B, 0x00, 0x03};

}  // namespace

TEST(Mbap, SplitsAStreamFedByteByByteAndTwoAdusInOneRead) {
    MbapReader reader;
    for (std::size_t i = 0; i + 1 < kRead.size(); ++i) {
        reader.feed(std::span(&kRead[i], 1));
        auto next = reader.next();
        ASSERT_TRUE(next.has_value());
        EXPECT_FALSE(next->has_value()) << "complete after " << i + 1 << " bytes";
    }
    reader.feed(std::span(&kRead.back(), 1));
    auto adu = reader.next();
    ASSERT_TRUE(adu && adu->has_value());
    EXPECT_EQ((*adu)->transaction, 1);
    EXPECT_EQ((*adu)->unit, 0x11);
    EXPECT_EQ((*adu)->pdu, (Bytes{0x03, 0x00, 0x6B, 0x00, 0x03}));

    Bytes two = kRead;
    two.insert(two.end(), kRead.begin(), kRead.end());
    two[kRead.size() + 7] = 0x04;  // the second one reads input registers
    reader.feed(two);
    auto first = reader.next();
    auto second = reader.next();
    ASSERT_TRUE(first && first->has_value() && second && second->has_value());
    EXPECT_EQ((*first)->pdu[0], 0x03);
    EXPECT_EQ((*second)->pdu[0], 0x04);
    EXPECT_EQ(reader.pending(), 0U);
}

TEST(Mbap, RefusesAStreamThatIsNotModbusTcp) {
    MbapReader http;
    const std::string get = "GET / HTTP/1.1\r\n";
    http.feed(std::span(reinterpret_cast<const std::uint8_t*>(get.data()), get.size()));
    auto r = http.next();
    ASSERT_FALSE(r.has_value());
    EXPECT_EQ(r.error(), StreamError::ProtocolId);

    MbapReader shortLength;
    shortLength.feed(Bytes{0, 1, 0, 0, 0, 1, 1});
    ASSERT_FALSE(shortLength.next().has_value());
    MbapReader longLength;
    longLength.feed(Bytes{0, 1, 0, 0, 0x01, 0x00, 1});  // 256: more than unit + 253
    auto l = longLength.next();
    ASSERT_FALSE(l.has_value());
    EXPECT_EQ(l.error(), StreamError::Length);
}

TEST(Mbap, EncodesTheHeaderBeforeThePdu) {
    const Bytes pdu{0x03, 0x06, 0x02, 0x2B, 0x00, 0x00, 0x00, 0x64};  // 6.3's answer
    EXPECT_EQ(encode(0x1234, 0x11, pdu),
              (Bytes{0x12, 0x34, 0x00, 0x00, 0x00, 0x09, 0x11, 0x03, 0x06, 0x02, 0x2B, 0x00, 0x00, 0x00, 0x64}));
}

TEST(Pdu, ParsesEachFunctionAndRefusesWhatItDoesNotServe) {
    auto read = parse_request(Bytes{0x04, 0xFD, 0x00, 0x00, 0x02});
    ASSERT_TRUE(read);
    const auto& r = std::get<ReadRegisters>(*read);
    EXPECT_EQ(r.function, 0x04);
    EXPECT_EQ(r.start, 0xFD00);
    EXPECT_EQ(r.count, 2);

    auto write = parse_request(Bytes{0x10, 0xFA, 0x00, 0x00, 0x02, 0x04, 0xC4, 0x00, 0x0B, 0xB8});
    ASSERT_TRUE(write);
    EXPECT_EQ(std::get<WriteRegisters>(*write).values, (std::vector<std::uint16_t>{0xC400, 3000}));

    const auto refused = [](const Bytes& pdu) {
        const auto parsed = parse_request(pdu);
        EXPECT_FALSE(parsed.has_value());
        return parsed ? Exception{} : parsed.error().exception;
    };
    EXPECT_EQ(refused({0x03, 0x00, 0x00, 0x00, 0x00}), Exception::IllegalDataValue);  // count 0
    EXPECT_EQ(refused({0x03, 0x00, 0x00, 0x00, 126}), Exception::IllegalDataValue);
    EXPECT_EQ(refused({0x03, 0xFF, 0xFF, 0x00, 0x02}), Exception::IllegalDataAddress);  // past 0xFFFF
    EXPECT_EQ(refused({0x10, 0xFA, 0x00, 0x00, 0x02, 0x03, 0xC4, 0x00, 0x0B}), Exception::IllegalDataValue);
    EXPECT_EQ(refused({0x06, 0xFA, 0x00, 0x00}), Exception::IllegalDataValue);
    EXPECT_EQ(refused({0x01, 0x00, 0x00, 0x00, 0x01}), Exception::IllegalFunction);  // coils
    EXPECT_EQ(refused({0x2B, 0x0D, 0x00, 0x00}), Exception::IllegalFunction);        // CANopen
    EXPECT_EQ(refused({0x2B, 0x0E, 0x02, 0x00}), Exception::IllegalDataValue);       // regular objects
    EXPECT_EQ(refused({0x2B, 0x0E, 0x04, 0x05}), Exception::IllegalDataAddress);
    EXPECT_EQ(refused({0x08, 0x00}), Exception::IllegalDataValue);
    EXPECT_EQ(exception_pdu(0x10, Exception::ServerDeviceBusy), (Bytes{0x90, 0x06}));
}

TEST(Pdu, AnswersDeviceIdentificationWithTheObjectsAsked) {
    const std::vector<std::pair<std::uint8_t, std::string>> objects{{0, "SCHNEIDER"}, {1, "ATV21"}, {2, "V1.1"}};
    const auto all = device_id_pdu(ReadDeviceId{1, 0}, objects);
    ASSERT_GE(all.size(), 7U);
    EXPECT_EQ(Bytes(all.begin(), all.begin() + 7), (Bytes{0x2B, 0x0E, 0x01, 0x81, 0x00, 0x00, 0x03}));
    EXPECT_EQ(all.size(), 7U + 2 + 9 + 2 + 5 + 2 + 4);
    const auto one = device_id_pdu(ReadDeviceId{4, 1}, objects);
    EXPECT_EQ(one, (Bytes{0x2B, 0x0E, 0x04, 0x81, 0x00, 0x00, 0x01, 0x01, 0x05, 'A', 'T', 'V', '2', '1'}));
}

TEST(Network, MatchesPrefixesOfBothFamiliesAndRefusesAmbiguousOnes) {
    const auto lan = Network::parse("192.168.10.0/24");
    ASSERT_TRUE(lan) << lan.error();
    Address peer;
    peer.bytes = {192, 168, 10, 77};
    EXPECT_TRUE(lan->contains(peer));
    peer.bytes[2] = 11;
    EXPECT_FALSE(lan->contains(peer));

    sockaddr_storage mapped{};
    sockaddr_in6 in6{};
    in6.sin6_family = AF_INET6;
    in6.sin6_addr.s6_addr[10] = 0xFF;
    in6.sin6_addr.s6_addr[11] = 0xFF;
    in6.sin6_addr.s6_addr[12] = 192;
    in6.sin6_addr.s6_addr[13] = 168;
    in6.sin6_addr.s6_addr[14] = 10;
    in6.sin6_addr.s6_addr[15] = 5;
    std::memcpy(&mapped, &in6, sizeof in6);
    const auto v4 = from_sockaddr(mapped);
    EXPECT_FALSE(v4.v6);
    EXPECT_TRUE(lan->contains(v4)) << v4.to_string();

    const auto loop6 = Network::parse("::1");
    ASSERT_TRUE(loop6);
    EXPECT_FALSE(loop6->contains(v4));
    EXPECT_FALSE(Network::parse("10.0.0.5/8").has_value());
    EXPECT_FALSE(Network::parse("10.0.0.0/33").has_value());
    EXPECT_FALSE(Network::parse("plant-lan").has_value());

    EXPECT_EQ(parse_endpoint("[::1]:1502")->host, "::1");
    EXPECT_EQ(parse_endpoint("*:502")->host, "");
    EXPECT_FALSE(parse_endpoint("::1:502").has_value());  // IPv6 without brackets
    EXPECT_FALSE(parse_endpoint("127.0.0.1:70000").has_value());
}

TEST(GatewayConfig, DefaultsAreLoopbackAndReadOnly) {
    const auto c = parse_config("", "gateway.toml");
    ASSERT_TRUE(c) << c.error().message;
    EXPECT_EQ(c->listen.host, "127.0.0.1");
    EXPECT_EQ(c->listen.port, 502);
    EXPECT_TRUE(c->write_from.empty());
    EXPECT_EQ(c->max_age, std::chrono::milliseconds(1000));
}

TEST(GatewayConfig, ReadsEveryKeyAndNamesTheOneThatIsWrong) {
    const auto c = parse_config(R"(
[gateway]
listen = "[::]:1502"
bus = "line1"
max_age = "250ms"
request_timeout = "1s"
idle_timeout = "30s"
max_connections = 8
max_pipelined = 4
workers = 2
allow_from = ["10.0.0.0/8", "::1"]
write_from = ["10.1.2.0/24"]
[[unit]]
id = 10
drive = "pump"
[[unit]]
id = 11
bus = "line2"
drive = "3"
)",
                                "gateway.toml");
    ASSERT_TRUE(c) << c.error().message;
    EXPECT_EQ(c->listen.host, "::");
    EXPECT_EQ(c->max_age, std::chrono::milliseconds(250));
    EXPECT_EQ(c->max_connections, 8U);
    ASSERT_EQ(c->units.size(), 2U);
    EXPECT_EQ(c->units[1].bus, "line2");
    EXPECT_EQ(c->write_from.size(), 1U);

    const auto error = [](const std::string& text) {
        const auto r = parse_config(text, "gateway.toml");
        EXPECT_FALSE(r.has_value()) << text;
        return r ? std::string() : r.error().message;
    };
    EXPECT_NE(error("[gateway]\nlisten = \"localhost:502\"\n").find("listen"), std::string::npos);
    EXPECT_NE(error("[gateway]\nmax_agee = \"1s\"\n").find("max_agee"), std::string::npos);
    EXPECT_NE(error("[gateway]\nmax_age = \"1\"\n").find("max_age"), std::string::npos);
    EXPECT_NE(error("[gateway]\nwrite_from = [\"10.0.0.1/8\"]\n").find("write_from"), std::string::npos);
    EXPECT_NE(error("[gateway]\nworkers = 0\n").find("workers"), std::string::npos);
    EXPECT_NE(error("[[unit]]\nid = 248\ndrive = \"pump\"\n").find("id"), std::string::npos);
    EXPECT_NE(error("[[unit]]\nid = 5\n").find("drive"), std::string::npos);
    EXPECT_NE(error("[[unit]]\nid = 5\ndrive = \"a\"\n[[unit]]\nid = 5\ndrive = \"b\"\n").find("twice"),
              std::string::npos);
    EXPECT_NE(error("[gateway\n").find("line 1"), std::string::npos);
}

namespace {

shm::DriveSnapshot snapshot_with(std::initializer_list<std::pair<std::uint16_t, std::uint16_t>> registers,
                                 std::int64_t time_ns) {
    shm::DriveSnapshot s;
    s.health = shm::DriveHealth::Online;
    for (const auto& [address, value] : registers) {
        auto& r = s.registers[s.register_count++];
        r.address = address;
        r.value = value;
        r.valid = 1;
        r.time_ns = time_ns;
    }
    return s;
}

Context context_for(const shm::DriveSnapshot* snapshot, std::int64_t now_ns, bool may_write = false) {
    Context c;
    c.drive = "pump";
    c.snapshot = snapshot;
    c.now_ns = now_ns;
    c.max_age_ns = 500'000'000;
    c.may_write = may_write;
    return c;
}

constexpr std::int64_t kSecond = 1'000'000'000;

}  // namespace

TEST(Route, AFreshPolledReadIsAnsweredFromTheSnapshotAndAnythingElseGoesToDrivebusd) {
    const auto snap = snapshot_with({{0xFD00, 3000}, {0xFD01, 0x0001}}, 10 * kSecond);
    const Call both = ReadRegisters{0x03, 0xFD00, 2};
    const auto fresh = decide(both, context_for(&snap, 10 * kSecond + kSecond / 10));
    ASSERT_TRUE(std::holds_alternative<Answer>(fresh));
    EXPECT_EQ(std::get<Answer>(fresh).pdu, (Bytes{0x03, 0x04, 0x0B, 0xB8, 0x00, 0x01}));
    EXPECT_TRUE(std::get<Answer>(fresh).from_snapshot);

    const auto stale = decide(both, context_for(&snap, 11 * kSecond));
    ASSERT_TRUE(std::holds_alternative<Send>(stale));
    const auto& request = std::get<Send>(stale).request;
    EXPECT_EQ(request.kind, shm::RequestKind::Read);
    EXPECT_EQ(request.start, 0xFD00);
    EXPECT_EQ(request.count, 2);
    EXPECT_EQ(shm::view(request.drive), "pump");

    const Call partly = ReadRegisters{0x04, 0xFD01, 2};  // FD02 is not polled
    EXPECT_TRUE(std::holds_alternative<Send>(decide(partly, context_for(&snap, 10 * kSecond))));
    auto invalid = snap;
    invalid.registers[0].valid = 0;
    EXPECT_TRUE(std::holds_alternative<Send>(decide(both, context_for(&invalid, 10 * kSecond))));
    EXPECT_TRUE(std::holds_alternative<Send>(decide(both, context_for(nullptr, 10 * kSecond))));

    // A write through the gateway acknowledged after the poll: the polled value is not served.
    const std::map<std::uint16_t, std::int64_t> written{{0xFD01, 10 * kSecond + 1}};
    auto after_write = context_for(&snap, 10 * kSecond + 2);
    after_write.written = &written;
    EXPECT_TRUE(std::holds_alternative<Send>(decide(both, after_write)));
    EXPECT_TRUE(std::holds_alternative<Answer>(decide(ReadRegisters{0x03, 0xFD00, 1}, after_write)));
}

TEST(Route, AnAbsentDriveIsAnswered0x0BWithoutLineTime) {
    auto snap = snapshot_with({{0xFD00, 3000}}, 10 * kSecond);
    snap.health = shm::DriveHealth::Absent;
    for (const Call& call :
         {Call{ReadRegisters{0x03, 0xFD06, 1}}, Call{ReadDeviceId{1, 0}}, Call{Diagnostic{0, {0x12, 0x34}}}}) {
        const auto d = decide(call, context_for(&snap, 10 * kSecond));
        ASSERT_TRUE(std::holds_alternative<Answer>(d));
        EXPECT_EQ(std::get<Answer>(d).pdu.at(1), 0x0B);
    }
}

TEST(Route, AWriteIsRefusedUnlessThePeerMayWrite) {
    const Call write = WriteRegisters{0x10, 0xFA00, {0xC400, 3000}};
    const auto refused = decide(write, context_for(nullptr, 0, false));
    ASSERT_TRUE(std::holds_alternative<Answer>(refused));
    EXPECT_EQ(std::get<Answer>(refused).pdu, (Bytes{0x90, 0x01}));
    EXPECT_FALSE(std::get<Answer>(refused).refused_write.empty());

    const auto sent = decide(write, context_for(nullptr, 0, true));
    ASSERT_TRUE(std::holds_alternative<Send>(sent));
    const auto& r = std::get<Send>(sent).request;
    EXPECT_EQ(r.kind, shm::RequestKind::Write);
    EXPECT_EQ(r.function, 0x10);
    EXPECT_EQ(r.count, 2);
    EXPECT_EQ(r.values[1], 3000);
}

TEST(Route, DiagnosticsEchoAndCountFromTheSnapshot) {
    auto snap = snapshot_with({}, 0);
    snap.counters.requests = 0x10005;
    snap.counters.timeouts = 7;
    const auto echo = decide(Diagnostic{0x0000, {0xA5, 0x37}}, context_for(&snap, 0));
    EXPECT_EQ(std::get<Answer>(echo).pdu, (Bytes{0x08, 0x00, 0x00, 0xA5, 0x37}));
    const auto messages = decide(Diagnostic{0x000B, {0, 0}}, context_for(&snap, 0));
    EXPECT_EQ(std::get<Answer>(messages).pdu, (Bytes{0x08, 0x00, 0x0B, 0x00, 0x05}));
    const auto silent = decide(Diagnostic{0x000F, {0, 0}}, context_for(&snap, 0));
    EXPECT_EQ(std::get<Answer>(silent).pdu, (Bytes{0x08, 0x00, 0x0F, 0x00, 0x07}));
    const auto clear = decide(Diagnostic{0x000A, {0, 0}}, context_for(&snap, 0));  // drivebusd's counters stay
    EXPECT_EQ(std::get<Answer>(clear).pdu, (Bytes{0x88, 0x01}));
}

TEST(Route, EveryOutcomeMapsToTheExceptionGatewaysUse) {
    const Call read = ReadRegisters{0x03, 0xFD06, 1};
    const auto with = [&](shm::Status status, shm::RejectReason reason = shm::RejectReason::None,
                          std::uint8_t exception = 0) {
        shm::Response r;
        r.status = status;
        r.reason = reason;
        r.exception = exception;
        return answer(read, r);
    };
    EXPECT_EQ(with(shm::Status::Exception, {}, 2), (Bytes{0x83, 0x02}));
    EXPECT_EQ(with(shm::Status::Timeout), (Bytes{0x83, 0x0B}));
    EXPECT_EQ(with(shm::Status::Late), (Bytes{0x83, 0x0B}));
    EXPECT_EQ(with(shm::Status::BadFrame), (Bytes{0x83, 0x0B}));
    EXPECT_EQ(with(shm::Status::BusDown), (Bytes{0x83, 0x0A}));
    EXPECT_EQ(with(shm::Status::QueueFull), (Bytes{0x83, 0x06}));
    EXPECT_EQ(with(shm::Status::NotPermitted), (Bytes{0x83, 0x06}));
    EXPECT_EQ(with(shm::Status::Rejected, shm::RejectReason::UnknownRegister), (Bytes{0x83, 0x02}));
    EXPECT_EQ(with(shm::Status::Rejected, shm::RejectReason::ReadOnly), (Bytes{0x83, 0x02}));
    EXPECT_EQ(with(shm::Status::Rejected, shm::RejectReason::ValueOutOfRange), (Bytes{0x83, 0x03}));
    EXPECT_EQ(with(shm::Status::Rejected, shm::RejectReason::Quantity), (Bytes{0x83, 0x03}));
    EXPECT_EQ(with(shm::Status::Rejected, shm::RejectReason::Unsupported), (Bytes{0x83, 0x01}));
    EXPECT_EQ(with(shm::Status::Rejected, shm::RejectReason::UnknownDrive), (Bytes{0x83, 0x0A}));
    Error gone;
    gone.kind = ErrorKind::DaemonGone;
    EXPECT_EQ(answer(read, std::unexpected(gone)), (Bytes{0x83, 0x0A}));
    Error unknown;
    unknown.kind = ErrorKind::OutcomeUnknown;
    EXPECT_EQ(answer(read, std::unexpected(unknown)), (Bytes{0x83, 0x0B}));

    shm::Response ok;
    ok.count = 1;
    ok.values[0] = 0x1234;
    EXPECT_EQ(answer(read, ok), (Bytes{0x03, 0x02, 0x12, 0x34}));
    ok.count = 0;  // fewer words than asked: never passed on as a value
    EXPECT_EQ(answer(read, ok), (Bytes{0x83, 0x04}));
    EXPECT_EQ(answer(WriteRegisters{0x06, 0xFA01, {3000}}, shm::Response{}), (Bytes{0x06, 0xFA, 0x01, 0x0B, 0xB8}));
}
