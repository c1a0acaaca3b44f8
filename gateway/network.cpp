// SPDX-License-Identifier: Apache-2.0
#include "gateway/network.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>

#include <charconv>
#include <cstring>

namespace drivebus::gateway {
namespace {

bool parse_host(const std::string& text, Address& out) {
    in_addr v4{};
    if (::inet_pton(AF_INET, text.c_str(), &v4) == 1) {
        out.v6 = false;
        std::memcpy(out.bytes.data(), &v4, 4);
        return true;
    }
    in6_addr v6{};
    if (::inet_pton(AF_INET6, text.c_str(), &v6) == 1) {
        out.v6 = true;
        std::memcpy(out.bytes.data(), &v6, 16);
        return true;
    }
    return false;
}

template <typename T>
bool parse_number(std::string_view text, T& value) {
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
    return ec == std::errc{} && end == text.data() + text.size() && !text.empty();
}

}  // namespace

std::string Address::host() const {
    std::array<char, INET6_ADDRSTRLEN> text{};
    ::inet_ntop(v6 ? AF_INET6 : AF_INET, bytes.data(), text.data(), text.size());
    return text.data();
}

std::string Address::to_string() const {
    return (v6 ? "[" + host() + "]" : host()) + ":" + std::to_string(port);
}

Address from_sockaddr(const sockaddr_storage& address) noexcept {
    Address out;
    if (address.ss_family == AF_INET) {
        sockaddr_in in{};
        std::memcpy(&in, &address, sizeof in);
        std::memcpy(out.bytes.data(), &in.sin_addr, 4);
        out.port = ntohs(in.sin_port);
    } else if (address.ss_family == AF_INET6) {
        sockaddr_in6 in{};
        std::memcpy(&in, &address, sizeof in);
        out.port = ntohs(in.sin6_port);
        if (IN6_IS_ADDR_V4MAPPED(&in.sin6_addr)) {
            std::memcpy(out.bytes.data(), &in.sin6_addr.s6_addr[12], 4);
        } else {
            out.v6 = true;
            std::memcpy(out.bytes.data(), &in.sin6_addr, 16);
        }
    }
    return out;
}

std::expected<Network, std::string> Network::parse(std::string_view text) {
    Network n;
    n.text_ = std::string(text);
    const auto slash = text.find('/');
    const std::string host(text.substr(0, slash));
    if (!parse_host(host, n.base_)) {
        return std::unexpected("'" + n.text_ + "' is not an IPv4 or IPv6 network (\"192.168.10.0/24\", \"fd00::/8\")");
    }
    const unsigned bits = n.base_.v6 ? 128 : 32;
    n.prefix_ = bits;
    if (slash != std::string_view::npos && (!parse_number(text.substr(slash + 1), n.prefix_) || n.prefix_ > bits)) {
        return std::unexpected("'" + n.text_ + "': the prefix length must be 0 to " + std::to_string(bits));
    }
    // Host bits set ("10.0.0.5/8") would read as a mistake: refuse them rather than guess.
    for (unsigned bit = n.prefix_; bit < bits; ++bit) {
        if ((n.base_.bytes[bit / 8] & (0x80U >> (bit % 8))) != 0) {
            return std::unexpected("'" + n.text_ +
                                   "' has bits set past its prefix length: write the network's first address");
        }
    }
    return n;
}

bool Network::contains(const Address& address) const noexcept {
    if (address.v6 != base_.v6) {
        return false;
    }
    for (unsigned bit = 0; bit < prefix_; ++bit) {
        const auto mask = static_cast<std::uint8_t>(0x80U >> (bit % 8));
        if ((address.bytes[bit / 8] & mask) != (base_.bytes[bit / 8] & mask)) {
            return false;
        }
    }
    return true;
}

std::expected<Endpoint, std::string> parse_endpoint(std::string_view text) {
    const auto colon = text.rfind(':');
    if (colon == std::string_view::npos) {
        return std::unexpected("'" + std::string(text) +
                               "' is not HOST:PORT (\"127.0.0.1:502\", \"[::1]:502\", \"*:502\")");
    }
    Endpoint e;
    std::string_view host = text.substr(0, colon);
    if (host.size() >= 2 && host.front() == '[' && host.back() == ']') {
        host = host.substr(1, host.size() - 2);
    }
    e.host = host == "*" ? std::string() : std::string(host);
    Address probe;
    if (!e.host.empty() && (!parse_host(e.host, probe) || (probe.v6 && text.front() != '['))) {
        return std::unexpected("'" + std::string(text) +
                               "': the host must be a numeric address (\"[::1]:502\" for IPv6) or *");
    }
    unsigned port = 0;
    if (!parse_number(text.substr(colon + 1), port) || port > 0xFFFF) {
        return std::unexpected("'" + std::string(text) + "': the port must be 0 (any free one) to 65535");
    }
    e.port = static_cast<std::uint16_t>(port);
    return e;
}

}  // namespace drivebus::gateway
