// SPDX-License-Identifier: Apache-2.0
// A simulated Altivar 21, as its Modbus guide (1769688) describes it: indirect blocks at
// 0x1875 (read) and 0x1870 (write), device identification, the control word FA00 driving a
// motor whose output frequency ramps to the reference FA01, the status word FD01, faults with
// their history, and the Modbus time-out F803 that trips the drive with Err5.
#pragma once

#include <optional>

#include "drive.hpp"

namespace drivebus::sim {

class Atv21Drive final : public ProfileDrive {
public:
    Atv21Drive(rtu::SlaveAddress address, std::shared_ptr<const Profile> profile);

    void advance(rtu::Instant now) override;
    // "load" (motor load, % of rating, 0-200), "fh" (maximum frequency, Hz), "cmod"
    // (0 terminals, 2 serial link), "fmod" (1 VIA, 4 serial link).
    bool set_option(std::string_view key, double value) override;
    // Power off and on: the control parameters (RAM, guide 8.2) return to their initial
    // values, the fault and the motor stop, and F870-F879 as stored take effect.
    void power_cycle(rtu::Instant now) override;

    [[nodiscard]] double output_hz() const noexcept { return output_centi_hz_ / 100.0; }
    [[nodiscard]] bool faulted() const noexcept { return fault_.has_value(); }

    // Fault codes of the guide's fault table used by the model.
    static constexpr std::uint16_t kFaultEmergencyStop = 17;  // E
    static constexpr std::uint16_t kFaultModbusTimeout = 24;  // Err5

private:
    rtu::Response read(const rtu::ReadHoldingRegisters& request, rtu::Instant now) override;
    rtu::Response write_multiple(const rtu::WriteMultipleRegisters& request, rtu::Instant now) override;
    rtu::Response identify(const rtu::ReadDeviceIdentification& request, rtu::Instant now) override;
    void on_write(std::uint16_t address, std::uint16_t value, rtu::Instant now) override;
    [[nodiscard]] std::optional<rtu::ExceptionCode> refuse_write(std::uint16_t address,
                                                                 std::uint16_t value) const override;
    void on_request(bool broadcast, rtu::Instant now) override;

    [[nodiscard]] std::uint16_t address_of(std::string_view name) const;
    [[nodiscard]] std::uint16_t reg(std::uint16_t address) const noexcept { return bank().get(address); }
    [[nodiscard]] bool control_bit(unsigned bit) const noexcept;
    [[nodiscard]] double target_centi_hz() const noexcept;
    void ramp_to(rtu::Instant t);
    void trip(std::uint16_t code);
    void publish();
    // F870-F879 take effect "après réinitialisation" (guide section 6): at power-up and when a
    // fault is reset. Until then each block keeps the selection it had.
    void apply_selectors();

    // Register addresses, resolved from the profile by name.
    std::uint16_t fa00_, fa01_, fd00_, fd01_, fe01_, fe03_, fe05_, fe90_, fc90_, fc91_, f603_, f803_, f856_, acc_;
    std::uint16_t fe10_, fe11_, fe12_, fe13_;
    const IndirectBlock* read_block_ = nullptr;
    const IndirectBlock* write_block_ = nullptr;
    std::vector<std::uint16_t> read_selectors_;   // F875-F879
    std::vector<std::uint16_t> write_selectors_;  // F870-F871
    // The selections in effect: what the selectors held at the last power-up or reset (the
    // selectors themselves when the profile says they take effect at once).
    std::vector<std::uint16_t> read_selection_;
    std::vector<std::uint16_t> write_selection_;

    // Motor and drive state.
    double output_centi_hz_ = 0.0;  // signed: negative is reverse
    bool accelerating_ = false;
    std::optional<std::uint16_t> fault_;
    std::optional<rtu::Instant> last_advance_;

    // Modbus time-out: the clock starts with the first valid request to this address.
    std::optional<rtu::Instant> last_valid_request_;

    // Settings that are not Modbus registers in the guide.
    double load_percent_ = 50.0;
    double max_centi_hz_ = 8000.0;  // FH; its number is not in the guide: 80.00 Hz
    int cmod_ = 0;                  // factory: terminal block
    int fmod_ = 1;                  // factory: VIA
};

}  // namespace drivebus::sim
