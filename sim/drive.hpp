// SPDX-License-Identifier: Apache-2.0
// A simulated drive: answers the requests addressed to it as the real drive would and lets
// time pass (ramps, time-outs). Pure: time is an argument, nothing here does I/O.
#pragma once

#include <cstdint>
#include <deque>
#include <expected>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "drivebus/profile.hpp"
#include "register_bank.hpp"
#include "rtu/pdu.hpp"
#include "rtu/timing.hpp"

namespace drivebus::sim {

// A drive whose behaviour is its profile: registers, access, ranges and function limits.
// The Altivar 58 is this; the Altivar 21 adds its indirect blocks, identification and motor.
class ProfileDrive {
public:
    ProfileDrive(rtu::SlaveAddress address, std::shared_ptr<const Profile> profile);
    virtual ~ProfileDrive() = default;
    ProfileDrive(const ProfileDrive&) = delete;
    ProfileDrive& operator=(const ProfileDrive&) = delete;
    ProfileDrive(ProfileDrive&&) = delete;
    ProfileDrive& operator=(ProfileDrive&&) = delete;

    [[nodiscard]] rtu::SlaveAddress address() const noexcept { return address_; }
    [[nodiscard]] const Profile& profile() const noexcept { return *profile_; }

    // A decoded request addressed to this drive, or broadcast (whose reply is not sent).
    [[nodiscard]] rtu::Response handle(const rtu::Request& request, bool broadcast, rtu::Instant now);
    // The last writes the drive accepted, oldest first: (register, value).
    [[nodiscard]] const std::deque<std::pair<std::uint16_t, std::uint16_t>>& write_log() const noexcept {
        return write_log_;
    }
    // The last requests addressed to the drive (broadcasts included), oldest first, however
    // they were answered: what reached it, in order.
    struct Received {
        std::uint8_t function = 0;
        std::uint16_t start = 0;
        std::optional<std::uint16_t> value;  // FC06's
    };
    [[nodiscard]] const std::deque<Received>& request_log() const noexcept { return request_log_; }
    [[nodiscard]] std::uint64_t requests_received() const noexcept { return requests_received_; }
    // How many register writes the drive has accepted since it started: the log keeps only the
    // last ones, so a reader that comes back tells from this how many of them are new.
    [[nodiscard]] std::uint64_t writes_accepted() const noexcept { return writes_accepted_; }
    // Lets time run to `now`.
    virtual void advance(rtu::Instant now);

    // Operator access from the control socket: any register, no access or range check.
    [[nodiscard]] std::expected<std::uint16_t, std::string> peek(std::string_view name) const;
    [[nodiscard]] std::expected<void, std::string> poke(std::string_view name, std::uint16_t value);
    // Operator settings that are not registers (motor load, ...); false if unknown.
    virtual bool set_option(std::string_view key, double value);
    // The drive is switched off and on again: what it keeps in RAM starts over, and what it
    // applies only at power-up takes effect. A plain profile drive keeps every register.
    virtual void power_cycle(rtu::Instant now);

protected:
    virtual rtu::Response read(const rtu::ReadHoldingRegisters& request, rtu::Instant now);
    virtual rtu::Response write_single(const rtu::WriteSingleRegister& request, rtu::Instant now);
    virtual rtu::Response write_multiple(const rtu::WriteMultipleRegisters& request, rtu::Instant now);
    virtual rtu::Response identify(const rtu::ReadDeviceIdentification& request, rtu::Instant now);
    // A master wrote `value` to `address` (already checked); the drive reacts.
    virtual void on_write(std::uint16_t address, std::uint16_t value, rtu::Instant now);
    // A drive-specific check of a write the profile allows (e.g. a reference above the
    // maximum frequency); nullopt accepts it.
    [[nodiscard]] virtual std::optional<rtu::ExceptionCode> refuse_write(std::uint16_t address,
                                                                         std::uint16_t value) const;
    // Called for every request before it is handled.
    virtual void on_request(bool broadcast, rtu::Instant now);

    static rtu::Response exception(rtu::FunctionCode function, rtu::ExceptionCode code);

    RegisterBank& bank() noexcept { return bank_; }
    [[nodiscard]] const RegisterBank& bank() const noexcept { return bank_; }

private:
    rtu::SlaveAddress address_;
    std::shared_ptr<const Profile> profile_;
    RegisterBank bank_;
    static constexpr std::size_t kWriteLogSize = 1024;
    void log_writes(const rtu::Request& request);
    std::deque<std::pair<std::uint16_t, std::uint16_t>> write_log_;
    std::uint64_t writes_accepted_ = 0;
    void log_request(const rtu::Request& request);
    std::deque<Received> request_log_;
    std::uint64_t requests_received_ = 0;
};

// Makes the drive for a profile type ("atv21", "atv58", or any other profile as a plain
// ProfileDrive).
[[nodiscard]] std::unique_ptr<ProfileDrive> make_drive(rtu::SlaveAddress address,
                                                       std::shared_ptr<const Profile> profile);

}  // namespace drivebus::sim
