// SPDX-License-Identifier: Apache-2.0
#include "atv21.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace drivebus::sim {

using rtu::ExceptionCode;
using rtu::FunctionCode;
using namespace std::chrono_literals;

namespace {

// FA00, control word (guide 8.4).
constexpr unsigned kCmdReverse = 9;
constexpr unsigned kCmdRun = 10;
constexpr unsigned kCmdFreewheel = 11;
constexpr unsigned kCmdEmergencyStop = 12;
constexpr unsigned kCmdFaultReset = 13;
constexpr unsigned kCmdReferencePriority = 14;
constexpr unsigned kCmdCommandPriority = 15;

// FD01, status word (guide 8.6).
constexpr unsigned kStFaultOutput = 0;
constexpr unsigned kStFault = 1;
constexpr unsigned kStAlarm = 2;
constexpr unsigned kStReverse = 9;
constexpr unsigned kStRunning = 10;
constexpr unsigned kStFreewheel = 11;
constexpr unsigned kStEmergencyStop = 12;
constexpr unsigned kStReadyStOn = 13;
constexpr unsigned kStReady = 14;

// FC91, alarm word.
constexpr unsigned kAlarmOvercurrent = 0;
constexpr unsigned kAlarmUndercurrent = 7;

// F603, behaviour on a Modbus fault.
constexpr std::uint16_t kStopDecelerate = 1;

constexpr std::uint16_t bit(unsigned n) {
    return static_cast<std::uint16_t>(1U << n);
}

std::uint16_t clamp_word(double v) {
    return static_cast<std::uint16_t>(std::clamp(std::lround(v), 0L, 65535L));
}

}  // namespace

Atv21Drive::Atv21Drive(rtu::SlaveAddress address, std::shared_ptr<const Profile> profile)
    : ProfileDrive(address, std::move(profile)),
      fa00_(address_of("FA00")),
      fa01_(address_of("FA01")),
      fd00_(address_of("FD00")),
      fd01_(address_of("FD01")),
      fe01_(address_of("FE01")),
      fe03_(address_of("FE03")),
      fe05_(address_of("FE05")),
      fe90_(address_of("FE90")),
      fc90_(address_of("FC90")),
      fc91_(address_of("FC91")),
      f603_(address_of("F603")),
      f803_(address_of("F803")),
      f856_(address_of("F856")),
      acc_(address_of("ACC")),
      fe10_(address_of("FE10")),
      fe11_(address_of("FE11")),
      fe12_(address_of("FE12")),
      fe13_(address_of("FE13")),
      read_block_(this->profile().block(3)),
      write_block_(this->profile().block(16)) {
    if (read_block_ == nullptr || write_block_ == nullptr) {
        throw std::runtime_error("profile " + this->profile().type + " lacks the Altivar 21 indirect blocks");
    }
    for (const auto& name : read_block_->selectors) {
        read_selectors_.push_back(address_of(name));
    }
    for (const auto& name : write_block_->selectors) {
        write_selectors_.push_back(address_of(name));
    }
    apply_selectors();
    publish();
}

void Atv21Drive::apply_selectors() {
    read_selection_.clear();
    for (const auto selector : read_selectors_) {
        read_selection_.push_back(reg(selector));
    }
    write_selection_.clear();
    for (const auto selector : write_selectors_) {
        write_selection_.push_back(reg(selector));
    }
}

void Atv21Drive::power_cycle(rtu::Instant now) {
    // Section 8.2 lists the parameters kept in RAM only: FA00, FA20, FA01, FA13, FA50, FA51.
    for (const RegisterInfo& info : profile().registers) {
        if (info.name.starts_with("FA") && info.address) {
            bank().put(*info.address, static_cast<std::uint16_t>(info.default_value.value_or(0)));
        }
    }
    fault_.reset();
    bank().put(fc90_, 0);
    output_centi_hz_ = 0.0;
    accelerating_ = false;
    last_advance_ = now;
    last_valid_request_.reset();  // the Modbus time-out starts again with the first request
    apply_selectors();
    publish();
}

std::uint16_t Atv21Drive::address_of(std::string_view name) const {
    const RegisterInfo* info = profile().find(name);
    if (info == nullptr || !info->address) {
        throw std::runtime_error("profile " + profile().type + " has no register " + std::string(name) +
                                 ", which the Altivar 21 model needs");
    }
    return *info->address;
}

bool Atv21Drive::set_option(std::string_view key, double value) {
    if (key == "load") {
        load_percent_ = std::clamp(value, 0.0, 200.0);
    } else if (key == "fh") {
        max_centi_hz_ = std::clamp(value, 0.5, 400.0) * 100.0;
    } else if (key == "cmod") {
        cmod_ = static_cast<int>(value);
    } else if (key == "fmod") {
        fmod_ = static_cast<int>(value);
    } else {
        return false;
    }
    publish();
    return true;
}

// ---- Modbus functions ----

rtu::Response Atv21Drive::read(const rtu::ReadHoldingRegisters& request, rtu::Instant now) {
    if (request.quantity == 1) {
        return ProfileDrive::read(request, now);
    }
    // 2-5 words only as the indirect block; any other start or quantity: exception 3 (7.5).
    if (request.start != read_block_->address || request.quantity < read_block_->min_quantity ||
        request.quantity > read_block_->max_quantity) {
        return exception(FunctionCode::ReadHoldingRegisters, ExceptionCode::IllegalDataValue);
    }
    rtu::ReadHoldingRegistersResponse reply;
    for (std::uint16_t slot = 0; slot < request.quantity; ++slot) {
        const std::uint16_t selection =
            read_block_->selectors_after_reset ? read_selection_[slot] : reg(read_selectors_[slot]);
        const auto choice = read_block_->choices.find(selection);
        const RegisterInfo* target =
            choice == read_block_->choices.end() ? nullptr : profile().find(std::string_view(choice->second));
        // A slot with no selection reads as 0.
        reply.values.push_back(target != nullptr && target->address ? reg(*target->address) : 0);
    }
    return reply;
}

rtu::Response Atv21Drive::write_multiple(const rtu::WriteMultipleRegisters& request, rtu::Instant now) {
    if (request.values.size() == 1) {
        return ProfileDrive::write_multiple(request, now);
    }
    if (request.start != write_block_->address || request.values.size() < write_block_->min_quantity ||
        request.values.size() > write_block_->max_quantity) {
        return exception(FunctionCode::WriteMultipleRegisters, ExceptionCode::IllegalDataValue);
    }
    // Resolve every slot first; the first slot must be configured (F870 = 0: exception 4, 7.8).
    std::vector<std::optional<std::uint16_t>> targets;
    for (std::size_t slot = 0; slot < request.values.size(); ++slot) {
        const std::uint16_t selection =
            write_block_->selectors_after_reset ? write_selection_[slot] : reg(write_selectors_[slot]);
        const auto choice = write_block_->choices.find(selection);
        const RegisterInfo* target =
            choice == write_block_->choices.end() ? nullptr : profile().find(std::string_view(choice->second));
        if (target == nullptr || !target->address) {
            if (slot == 0) {
                return exception(FunctionCode::WriteMultipleRegisters, ExceptionCode::ServerDeviceFailure);
            }
            targets.emplace_back();  // unselected slot: its word is ignored
            continue;
        }
        if (auto ok = bank().check_write(*target->address, request.values[slot]); !ok) {
            return exception(FunctionCode::WriteMultipleRegisters, ok.error());
        }
        if (const auto refused = refuse_write(*target->address, request.values[slot])) {
            return exception(FunctionCode::WriteMultipleRegisters, *refused);
        }
        targets.emplace_back(*target->address);
    }
    for (std::size_t slot = 0; slot < targets.size(); ++slot) {
        if (targets[slot]) {
            bank().put(*targets[slot], request.values[slot]);
            on_write(*targets[slot], request.values[slot], now);
        }
    }
    return rtu::WriteMultipleRegistersResponse{request.start, static_cast<std::uint16_t>(request.values.size())};
}

rtu::Response Atv21Drive::identify(const rtu::ReadDeviceIdentification& request, rtu::Instant /*now*/) {
    const auto& id = profile().identification;
    // Read codes 1-3 give the three basic objects; anything else is exception 3 (7.10).
    if (!id || request.code == rtu::DeviceIdCode::Specific) {
        return exception(FunctionCode::EncapsulatedInterface, ExceptionCode::IllegalDataValue);
    }
    rtu::DeviceIdentificationResponse reply;
    reply.code = request.code;
    reply.conformity = 0x01;
    reply.objects = {{0x00, id->vendor_name}, {0x01, id->product_code}, {0x02, id->revision}};
    return reply;
}

void Atv21Drive::on_request(bool broadcast, rtu::Instant now) {
    // Only requests to the drive's own address keep the Modbus time-out from expiring (6.4).
    if (!broadcast) {
        last_valid_request_ = now;
    }
}

void Atv21Drive::on_write(std::uint16_t address, std::uint16_t value, rtu::Instant now) {
    if (address == fa00_) {
        if ((value & bit(kCmdFaultReset)) != 0 && fault_) {
            // A reset after a fault (guide 8.2): what takes effect "after a reset" does now.
            fault_.reset();
            bank().put(fc90_, 0);
            last_valid_request_ = now;
            apply_selectors();
        }
        if ((value & bit(kCmdEmergencyStop)) != 0) {
            trip(kFaultEmergencyStop);
        }
        if ((value & bit(kCmdFreewheel)) != 0) {
            output_centi_hz_ = 0.0;  // the motor coasts: the drive's output stops at once
        }
    }
    publish();
}

std::optional<ExceptionCode> Atv21Drive::refuse_write(std::uint16_t address, std::uint16_t value) const {
    // The frequency reference ranges from 0 to the maximum frequency FH (8.5).
    if (address == fa01_ && value > max_centi_hz_) {
        return ExceptionCode::IllegalDataValue;
    }
    return std::nullopt;
}

// ---- the motor ----

bool Atv21Drive::control_bit(unsigned n) const noexcept {
    return (reg(fa00_) & bit(n)) != 0;
}

double Atv21Drive::target_centi_hz() const noexcept {
    const bool modbus_commands = control_bit(kCmdCommandPriority) || cmod_ == 2;
    const bool modbus_reference = control_bit(kCmdReferencePriority) || fmod_ == 4;
    const bool run = modbus_commands && control_bit(kCmdRun) && !control_bit(kCmdFreewheel) &&
                     !control_bit(kCmdEmergencyStop) && !fault_;
    if (!run) {
        return 0.0;
    }
    // The terminal inputs are not wired in the simulator: without the Modbus reference, 0 Hz.
    const double reference = modbus_reference ? std::min<double>(reg(fa01_), max_centi_hz_) : 0.0;
    return control_bit(kCmdReverse) ? -reference : reference;
}

void Atv21Drive::ramp_to(rtu::Instant t) {
    if (!last_advance_) {
        last_advance_ = t;
        return;
    }
    const double seconds = std::chrono::duration<double>(t - *last_advance_).count();
    last_advance_ = t;
    if (seconds <= 0.0) {
        return;
    }
    // ACC is the time from 0 Hz to FH; the guide gives no number for DEC, so decelerations
    // use the same rate.
    const double acc_seconds = reg(acc_) * 0.1;
    const double target = fault_ && reg(f603_) != kStopDecelerate ? 0.0 : target_centi_hz();
    const double step = acc_seconds > 0.0 ? max_centi_hz_ * seconds / acc_seconds : 1e12;
    const double before = output_centi_hz_;
    if (output_centi_hz_ < target) {
        output_centi_hz_ = std::min(target, output_centi_hz_ + step);
    } else {
        output_centi_hz_ = std::max(target, output_centi_hz_ - step);
    }
    accelerating_ = std::abs(output_centi_hz_) > std::abs(before);
}

void Atv21Drive::advance(rtu::Instant now) {
    // The Modbus time-out (F803 seconds without a request to this address, once
    // communication has started) trips the drive at its exact moment.
    const std::uint16_t timeout_s = reg(f803_);
    if (timeout_s > 0 && last_valid_request_ && !fault_) {
        const rtu::Instant expiry = *last_valid_request_ + std::chrono::seconds(timeout_s);
        if (expiry <= now) {
            ramp_to(expiry);
            trip(kFaultModbusTimeout);
        }
    }
    ramp_to(now);
    publish();
}

void Atv21Drive::trip(std::uint16_t code) {
    if (fault_) {
        return;
    }
    bank().put(fe01_, reg(fd01_));  // status just before the fault
    bank().put(fe13_, reg(fe12_));
    bank().put(fe12_, reg(fe11_));
    bank().put(fe11_, reg(fe10_));
    bank().put(fe10_, code);
    bank().put(fc90_, code);
    fault_ = code;
    // F603: 0 freewheel, 1 deceleration, 2 DC injection. All but deceleration stop the output.
    if (reg(f603_) != kStopDecelerate) {
        output_centi_hz_ = 0.0;
    }
    publish();
}

void Atv21Drive::publish() {
    const double hz = std::abs(output_centi_hz_);
    const bool turning = hz >= 1.0;
    const bool commanded = target_centi_hz() != 0.0;

    // Output current follows the load: magnetising current plus the load share, more while
    // accelerating; none when the output is off.
    double current = 0.0;
    if (turning || commanded) {
        current = 30.0 + 0.7 * load_percent_ + (accelerating_ ? 20.0 : 0.0);
    }
    const double voltage = max_centi_hz_ > 0.0 ? 100.0 * hz / max_centi_hz_ : 0.0;

    std::uint16_t alarms = 0;
    if (current > 120.0) {
        alarms |= bit(kAlarmOvercurrent);
    }
    if (turning && !accelerating_ && load_percent_ < 5.0) {
        alarms |= bit(kAlarmUndercurrent);
    }

    std::uint16_t status = 0;
    if (fault_) {
        status |= static_cast<std::uint16_t>(bit(kStFaultOutput) | bit(kStFault));
        if (*fault_ == kFaultEmergencyStop) {
            status |= bit(kStEmergencyStop);
        }
    } else {
        status |= bit(kStReady);
        if (commanded) {
            status |= bit(kStReadyStOn);
        }
    }
    if (alarms != 0) {
        status |= bit(kStAlarm);
    }
    if (turning || commanded) {
        status |= bit(kStRunning);
    }
    if (output_centi_hz_ < 0.0 || (output_centi_hz_ == 0.0 && control_bit(kCmdReverse))) {
        status |= bit(kStReverse);
    }
    if (control_bit(kCmdFreewheel)) {
        status |= bit(kStFreewheel);
    }

    std::uint16_t poles = reg(f856_);
    if (poles == 0) {
        poles = 4;
    }
    bank().put(fd00_, clamp_word(hz));
    bank().put(fd01_, status);
    bank().put(fe03_, clamp_word(current * 100.0));
    bank().put(fe05_, clamp_word(voltage * 100.0));
    bank().put(fc91_, alarms);
    bank().put(fe90_, clamp_word(hz / 100.0 * 120.0 / poles));
}

}  // namespace drivebus::sim
