// SPDX-License-Identifier: Apache-2.0
#include "drive.hpp"

#include <vector>

#include "atv21.hpp"

namespace drivebus::sim {

using rtu::ExceptionCode;
using rtu::FunctionCode;

ProfileDrive::ProfileDrive(rtu::SlaveAddress address, std::shared_ptr<const Profile> profile)
    : address_(address), profile_(std::move(profile)), bank_(*profile_) {}

rtu::Response ProfileDrive::exception(FunctionCode function, ExceptionCode code) {
    return rtu::ExceptionResponse{static_cast<std::uint8_t>(function), code};
}

rtu::Response ProfileDrive::handle(const rtu::Request& request, bool broadcast, rtu::Instant now) {
    advance(now);
    log_request(request);
    on_request(broadcast, now);
    struct Dispatch {
        ProfileDrive& drive;
        rtu::Instant now;
        rtu::Response operator()(const rtu::ReadHoldingRegisters& r) const { return drive.read(r, now); }
        rtu::Response operator()(const rtu::WriteSingleRegister& r) const { return drive.write_single(r, now); }
        rtu::Response operator()(const rtu::WriteMultipleRegisters& r) const { return drive.write_multiple(r, now); }
        rtu::Response operator()(const rtu::ReadDeviceIdentification& r) const { return drive.identify(r, now); }
    };
    auto response = std::visit(Dispatch{*this, now}, request);
    if (!std::holds_alternative<rtu::ExceptionResponse>(response)) {
        log_writes(request);
    }
    return response;
}

void ProfileDrive::log_request(const rtu::Request& request) {
    Received r;
    if (const auto* read = std::get_if<rtu::ReadHoldingRegisters>(&request)) {
        r = {3, read->start, std::nullopt};
    } else if (const auto* one = std::get_if<rtu::WriteSingleRegister>(&request)) {
        r = {6, one->address, one->value};
    } else if (const auto* many = std::get_if<rtu::WriteMultipleRegisters>(&request)) {
        r = {16, many->start, std::nullopt};
    } else {
        r = {43, 0, std::nullopt};
    }
    if (request_log_.size() == kWriteLogSize) {
        request_log_.pop_front();
    }
    request_log_.push_back(r);
    ++requests_received_;
}

void ProfileDrive::log_writes(const rtu::Request& request) {
    const auto add = [&](std::uint16_t address, std::uint16_t value) {
        if (write_log_.size() == kWriteLogSize) {
            write_log_.pop_front();
        }
        write_log_.emplace_back(address, value);
        ++writes_accepted_;
    };
    if (const auto* one = std::get_if<rtu::WriteSingleRegister>(&request)) {
        add(one->address, one->value);
    } else if (const auto* many = std::get_if<rtu::WriteMultipleRegisters>(&request)) {
        const auto words = many->values.words();
        for (std::size_t i = 0; i < words.size(); ++i) {
            add(static_cast<std::uint16_t>(many->start + i), words[i]);
        }
    }
}

void ProfileDrive::advance(rtu::Instant /*now*/) {}
std::optional<ExceptionCode> ProfileDrive::refuse_write(std::uint16_t /*address*/, std::uint16_t /*value*/) const {
    return std::nullopt;
}
void ProfileDrive::on_request(bool /*broadcast*/, rtu::Instant /*now*/) {}
void ProfileDrive::on_write(std::uint16_t /*address*/, std::uint16_t /*value*/, rtu::Instant /*now*/) {}
void ProfileDrive::power_cycle(rtu::Instant /*now*/) {}

bool ProfileDrive::set_option(std::string_view /*key*/, double /*value*/) {
    return false;
}

rtu::Response ProfileDrive::read(const rtu::ReadHoldingRegisters& request, rtu::Instant /*now*/) {
    if (request.quantity > profile().functions.read_holding_max) {
        return exception(FunctionCode::ReadHoldingRegisters, ExceptionCode::IllegalDataValue);
    }
    rtu::ReadHoldingRegistersResponse reply;
    for (std::uint32_t a = request.start; a < request.start + std::uint32_t{request.quantity}; ++a) {
        const auto value = bank_.read(static_cast<std::uint16_t>(a));
        if (!value) {
            return exception(FunctionCode::ReadHoldingRegisters, value.error());
        }
        reply.values.push_back(*value);
    }
    return reply;
}

rtu::Response ProfileDrive::write_single(const rtu::WriteSingleRegister& request, rtu::Instant now) {
    if (!profile().functions.write_single) {
        return exception(FunctionCode::WriteSingleRegister, ExceptionCode::IllegalFunction);
    }
    if (auto ok = bank_.check_write(request.address, request.value); !ok) {
        return exception(FunctionCode::WriteSingleRegister, ok.error());
    }
    if (const auto refused = refuse_write(request.address, request.value)) {
        return exception(FunctionCode::WriteSingleRegister, *refused);
    }
    bank_.put(request.address, request.value);
    on_write(request.address, request.value, now);
    return rtu::WriteSingleRegisterResponse{request.address, request.value};
}

rtu::Response ProfileDrive::write_multiple(const rtu::WriteMultipleRegisters& request, rtu::Instant now) {
    const auto quantity = static_cast<std::uint16_t>(request.values.size());
    if (quantity > profile().functions.write_multiple_max) {
        return exception(FunctionCode::WriteMultipleRegisters, ExceptionCode::IllegalDataValue);
    }
    // All or nothing: every word is checked before any is written.
    for (std::uint16_t i = 0; i < quantity; ++i) {
        const auto address = static_cast<std::uint16_t>(request.start + i);
        if (auto ok = bank_.check_write(address, request.values[i]); !ok) {
            return exception(FunctionCode::WriteMultipleRegisters, ok.error());
        }
        if (const auto refused = refuse_write(address, request.values[i])) {
            return exception(FunctionCode::WriteMultipleRegisters, *refused);
        }
    }
    for (std::uint16_t i = 0; i < quantity; ++i) {
        const auto address = static_cast<std::uint16_t>(request.start + i);
        bank_.put(address, request.values[i]);
        on_write(address, request.values[i], now);
    }
    return rtu::WriteMultipleRegistersResponse{request.start, quantity};
}

rtu::Response ProfileDrive::identify(const rtu::ReadDeviceIdentification& /*request*/, rtu::Instant /*now*/) {
    return exception(FunctionCode::EncapsulatedInterface, ExceptionCode::IllegalFunction);
}

std::expected<std::uint16_t, std::string> ProfileDrive::peek(std::string_view name) const {
    const RegisterInfo* info = profile().find(name);
    if (info == nullptr || !info->address) {
        return std::unexpected("no register " + std::string(name) + " in profile " + profile().type);
    }
    return bank_.get(*info->address);
}

std::expected<void, std::string> ProfileDrive::poke(std::string_view name, std::uint16_t value) {
    const RegisterInfo* info = profile().find(name);
    if (info == nullptr || !info->address) {
        return std::unexpected("no register " + std::string(name) + " in profile " + profile().type);
    }
    bank_.put(*info->address, value);
    return {};
}

std::unique_ptr<ProfileDrive> make_drive(rtu::SlaveAddress address, std::shared_ptr<const Profile> profile) {
    if (profile->type == "atv21") {
        return std::make_unique<Atv21Drive>(address, std::move(profile));
    }
    return std::make_unique<ProfileDrive>(address, std::move(profile));
}

}  // namespace drivebus::sim
