// SPDX-License-Identifier: Apache-2.0
// What drivebusd does with a client's request before anything reaches the wire: find the drive,
// check the registers, quantities, values and function against the drive's profile, and build
// the Modbus request. Pure: no iceoryx, no clock. A rejection names the reason and the register.
//
// Every rule applies to the registers a request reaches, not to the address it names: a request
// through an indirect block is expanded to the registers its slots select, as drivebusd set the
// block up (config::block_setups), and refused when drivebusd has not. The registers drivebusd
// relies on (the blocks' selectors, its set-up writes) are refused to every client.
#pragma once

#include <cstddef>
#include <cstdint>
#include <expected>
#include <string>
#include <vector>

#include "config/config.hpp"
#include "drivebus/shm.hpp"
#include "rtu/pdu.hpp"

namespace drivebus::ipc {

inline constexpr std::size_t kBroadcast = static_cast<std::size_t>(-1);

struct Admitted {
    std::size_t drive = kBroadcast;  // index into the bus's drives
    rtu::RequestAdu request;         // unset for lease operations
    bool on_wire = true;             // false: LeaseRenew / LeaseRelease
    bool touches_control = false;    // writes a register of the profile's lease_registers
    // The registers read or written: the request's own, or those a block's slots select.
    std::vector<std::uint16_t> registers;
};

struct Rejection {
    shm::RejectReason reason = shm::RejectReason::Malformed;
    std::uint16_t register_address = 0;
    std::string why;  // one line for the log
};

[[nodiscard]] std::expected<Admitted, Rejection> admit(const config::BusConfig& bus, const shm::Request& request);

// The drive a request names (by name, else by address); nullopt when the bus has none such.
[[nodiscard]] std::optional<std::size_t> find_drive(const config::BusConfig& bus, const shm::Request& request);

}  // namespace drivebus::ipc
