// SPDX-License-Identifier: Apache-2.0
// Source networks for the gateway's access rules ("192.168.10.0/24", "::1/128", a bare address),
// and peers' addresses to test against them. An IPv4 peer on an IPv6 socket (::ffff:a.b.c.d) is
// taken as the IPv4 address it is.
#pragma once

#include <sys/socket.h>

#include <array>
#include <cstdint>
#include <expected>
#include <string>
#include <string_view>

namespace drivebus::gateway {

struct Address {
    bool v6 = false;
    std::array<std::uint8_t, 16> bytes{};  // IPv4: the first 4
    std::uint16_t port = 0;

    [[nodiscard]] std::string to_string() const;  // "10.0.0.5:50122", "[fd00::5]:50122"
    [[nodiscard]] std::string host() const;       // without the port
};

[[nodiscard]] Address from_sockaddr(const sockaddr_storage& address) noexcept;

class Network {
public:
    // "a.b.c.d/n", "x:y::/n" or a bare address (the one host); else what is wrong with it.
    [[nodiscard]] static std::expected<Network, std::string> parse(std::string_view text);
    [[nodiscard]] bool contains(const Address& address) const noexcept;
    [[nodiscard]] const std::string& text() const noexcept { return text_; }

private:
    Address base_;
    unsigned prefix_ = 0;
    std::string text_;
};

// "host:port", "[v6]:port" or "*:port" (every interface): for listen =. Port 0: any free port
// (the gateway logs the one it got).
struct Endpoint {
    std::string host;  // numeric; "" for every interface
    std::uint16_t port = 0;
};
[[nodiscard]] std::expected<Endpoint, std::string> parse_endpoint(std::string_view text);

}  // namespace drivebus::gateway
