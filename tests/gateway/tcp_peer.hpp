// SPDX-License-Identifier: Apache-2.0
// A blocking Modbus TCP client for the gateway's tests: raw MBAP over a loopback socket.
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>

#include <gtest/gtest.h>

#include <array>
#include <cerrno>
#include <optional>
#include <utility>
#include <vector>

#include "gateway/mbap.hpp"
#include "sys/posix.hpp"

namespace drivebus::gateway::test {

using Bytes = std::vector<std::uint8_t>;

// A blocking Modbus TCP client with a receive time-out.
class Peer {
public:
    explicit Peer(std::uint16_t port) : fd_(::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0)) {
        sockaddr_in to{};
        to.sin_family = AF_INET;
        to.sin_port = htons(port);
        to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
        connected_ = ::connect(fd_.get(), reinterpret_cast<const sockaddr*>(&to), sizeof to) == 0;
        const timeval timeout{10, 0};
        ::setsockopt(fd_.get(), SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
    }
    [[nodiscard]] bool connected() const { return connected_; }
    void send(const Bytes& bytes) const {
        ASSERT_EQ(::send(fd_.get(), bytes.data(), bytes.size(), MSG_NOSIGNAL), static_cast<ssize_t>(bytes.size()));
    }
    void request(std::uint16_t transaction, std::uint8_t unit, const Bytes& pdu) const {
        send(encode(transaction, unit, pdu));
    }
    // The next answer: transaction id and PDU; nothing when the server closed (or 10 s passed).
    std::optional<std::pair<std::uint16_t, Bytes>> answer() {
        for (;;) {
            if (auto adu = reader_.next(); adu && adu->has_value()) {
                return std::pair{(*adu)->transaction, (*adu)->pdu};
            }
            std::array<std::uint8_t, 512> buffer{};
            const auto n = ::recv(fd_.get(), buffer.data(), buffer.size(), 0);
            if (n <= 0) {
                return std::nullopt;
            }
            reader_.feed(std::span(buffer.data(), static_cast<std::size_t>(n)));
        }
    }
    // Whether the server closes the connection (within 10 s).
    bool closed_by_server() {
        std::array<std::uint8_t, 512> buffer{};
        for (;;) {
            const auto n = ::recv(fd_.get(), buffer.data(), buffer.size(), 0);
            if (n == 0) {
                return true;
            }
            if (n < 0) {
                return errno == ECONNRESET;
            }
        }
    }
    void close() { fd_.reset(); }
    [[nodiscard]] int fd() const { return fd_.get(); }

private:
    sys::UniqueFd fd_;
    bool connected_ = false;
    MbapReader reader_;
};

}  // namespace drivebus::gateway::test
