// SPDX-License-Identifier: Apache-2.0
#include "gateway/mbap.hpp"

#include <cassert>

namespace drivebus::gateway {
namespace {

std::uint16_t be16(const std::uint8_t* p) noexcept {
    return static_cast<std::uint16_t>((p[0] << 8) | p[1]);
}

}  // namespace

const char* to_string(StreamError error) noexcept {
    switch (error) {
    case StreamError::ProtocolId: return "not Modbus TCP (protocol id is not 0)";
    case StreamError::Length: return "MBAP length out of range (2..254)";
    }
    return "unknown stream error";
}

void MbapReader::feed(std::span<const std::uint8_t> bytes) {
    if (taken_ > 0) {
        buffer_.erase(buffer_.begin(), buffer_.begin() + static_cast<std::ptrdiff_t>(taken_));
        taken_ = 0;
    }
    buffer_.insert(buffer_.end(), bytes.begin(), bytes.end());
}

std::expected<std::optional<Adu>, StreamError> MbapReader::next() {
    const std::size_t held = buffer_.size() - taken_;
    if (held < kMbapHeaderSize) {
        return std::nullopt;
    }
    const std::uint8_t* h = buffer_.data() + taken_;
    if (be16(h + 2) != 0) {
        return std::unexpected(StreamError::ProtocolId);
    }
    const std::size_t length = be16(h + 4);  // unit id + PDU
    if (length < 2 || length > kMaxPduSize + 1) {
        return std::unexpected(StreamError::Length);
    }
    const std::size_t whole = kMbapHeaderSize - 1 + length;
    if (held < whole) {
        return std::nullopt;
    }
    Adu adu;
    adu.transaction = be16(h);
    adu.unit = h[6];
    adu.pdu.assign(h + kMbapHeaderSize, h + whole);
    taken_ += whole;
    return adu;
}

std::vector<std::uint8_t> encode(std::uint16_t transaction, std::uint8_t unit, std::span<const std::uint8_t> pdu) {
    assert(pdu.size() <= kMaxPduSize);
    const auto length = static_cast<std::uint16_t>(pdu.size() + 1);
    std::vector<std::uint8_t> out;
    out.reserve(kMbapHeaderSize + pdu.size());
    out.push_back(static_cast<std::uint8_t>(transaction >> 8));
    out.push_back(static_cast<std::uint8_t>(transaction & 0xFF));
    out.push_back(0);
    out.push_back(0);
    out.push_back(static_cast<std::uint8_t>(length >> 8));
    out.push_back(static_cast<std::uint8_t>(length & 0xFF));
    out.push_back(unit);
    out.insert(out.end(), pdu.begin(), pdu.end());
    return out;
}

}  // namespace drivebus::gateway
