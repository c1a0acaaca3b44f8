// SPDX-License-Identifier: Apache-2.0
// Altivar helpers with units, on top of a Drive: what the drive's profile says in its
// [control] section (command word values, status bits, fault and alarm registers).
//
//   drivebus::Altivar pump(*bus->drive("pump"));
//   pump.set_frequency(50.0);   // Hz, through the profile's scale (FA01: 0.01 Hz)
//   pump.run_forward();
//   auto state = pump.state();  // running, fault name, alarms, output frequency
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "drivebus/client.hpp"

namespace drivebus {

struct DriveState {
    std::uint64_t sequence = 0;  // of the snapshot it was decoded from
    shm::DriveHealth health = shm::DriveHealth::Unknown;
    std::optional<std::uint16_t> status_word;
    bool running = false;
    bool reverse = false;
    bool fault = false;
    bool alarm = false;
    bool ready = false;
    std::vector<std::string> flags;  // the meaning of each status bit set, from the profile
    std::optional<double> output_hz;
    std::optional<std::uint16_t> fault_code;
    std::string fault_name;           // "Err5"
    std::string fault_title;          // "Modbus communication time-out"
    std::vector<std::string> alarms;  // the meaning of each alarm bit set
    shm::LeaseStatus lease{};
};

// Decodes a snapshot with the drive's profile. Values the snapshot lacks (not polled) stay unset.
[[nodiscard]] DRIVEBUS_API DriveState decode_state(const Profile& profile, const shm::DriveSnapshot& snapshot);

class DRIVEBUS_API Altivar {
public:
    explicit Altivar(Drive drive) : drive_(std::move(drive)) {}

    [[nodiscard]] const Drive& drive() const noexcept { return drive_; }

    // Writes the reference register in Hz (the profile's unit and scale; range checked).
    [[nodiscard]] std::expected<void, Error> set_frequency(double hz, WriteOptions options = {}) const;
    [[nodiscard]] std::expected<void, Error> run_forward(WriteOptions options = {}) const;
    [[nodiscard]] std::expected<void, Error> run_reverse(WriteOptions options = {}) const;
    [[nodiscard]] std::expected<void, Error> stop(WriteOptions options = {}) const;       // ramp stop
    [[nodiscard]] std::expected<void, Error> freewheel(WriteOptions options = {}) const;  // coast
    [[nodiscard]] std::expected<void, Error> reset_fault(WriteOptions options = {}) const;

    // The latest snapshot, decoded (waits up to `wait` for the first).
    [[nodiscard]] std::expected<DriveState, Error> state(Milliseconds wait = Milliseconds(1000)) const;

    // The same writes, completed by `done` in a later Bus::dispatch() (Delivery::Dispatch, as
    // Drive::async_write). What is refused before anything is sent (no profile, no such command
    // word, a frequency out of range) calls `done` at once, before the call returns.
    void async_set_frequency(double hz, Drive::Done done, WriteOptions options = {}) const;
    void async_run_forward(Drive::Done done, WriteOptions options = {}) const;
    void async_run_reverse(Drive::Done done, WriteOptions options = {}) const;
    void async_stop(Drive::Done done, WriteOptions options = {}) const;
    void async_freewheel(Drive::Done done, WriteOptions options = {}) const;
    void async_reset_fault(Drive::Done done, WriteOptions options = {}) const;

private:
    [[nodiscard]] std::expected<void, Error> command(const std::optional<std::uint16_t> ControlInfo::* word,
                                                     const char* what, WriteOptions options) const;
    Drive drive_;
};

}  // namespace drivebus
