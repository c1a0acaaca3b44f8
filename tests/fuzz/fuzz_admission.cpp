// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: admission of a raw shm::Request, as a client could leave any bytes in the
// request chunk. The bus has an Altivar 21 (address 1) and an Altivar 58 (address 2) with the
// shipped profiles. Whatever the bytes, an admitted request goes to the drive it names, asks
// the wire for exactly what the client asked, touches only registers its profile lists with the
// access it needs (or the profile's indirect block), writes only values in range, passes the
// codec's checks for that profile and encodes; a rejection gives a reason.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <variant>

#include "bus_toml.hpp"
#include "config/config.hpp"
#include "fuzz_support.hpp"
#include "ipc/admission.hpp"
#include "master/scheduler.hpp"
#include "rtu/codec.hpp"

using namespace drivebus;
using fuzz::check;

namespace {

const config::BusConfig& bus() {
    static const config::BusConfig b = [] {
        config::LoadOptions options;
        options.profile_dir = DRIVEBUS_FUZZ_PROFILE_DIR;
        auto c = config::parse_config(test::pump_and_fan_toml(), "fuzz.toml", options);
        if (!c) {
            fuzz::fail(c.error().message);
        }
        return c->buses.at(0);
    }();
    return b;
}

bool in_block(const Profile& p, std::uint8_t function, std::uint16_t start, std::size_t count) {
    const auto* block = p.block(function);
    return block != nullptr && block->address == start && count >= block->min_quantity && count <= block->max_quantity;
}

// Every word of the range is a register of the profile that allows this access (and, for a
// write, the value); or the range is the profile's indirect block for the function.
void check_registers(const Profile& p, std::uint8_t function, std::uint16_t start, std::size_t count,
                     const std::uint16_t* values) {
    if (p.registers.empty() || in_block(p, function, start, count)) {
        return;
    }
    check(static_cast<std::size_t>(start) + count <= 0x10000, "a range past register 0xFFFF");
    for (std::size_t i = 0; i < count; ++i) {
        const auto* r = p.find(static_cast<std::uint16_t>(start + i));
        check(r != nullptr, "admitted a register the profile does not list");
        if (values == nullptr) {
            check(readable(r->access), "admitted a read of a write-only register");
        } else {
            check(writable(r->access), "admitted a write of a read-only register");
            check(r->in_range(values[i]), "admitted a value outside the register's range");
        }
    }
}

void check_admitted(const shm::Request& q, const ipc::Admitted& a) {
    const auto& b = bus();
    if (!a.on_wire) {
        check(q.kind == shm::RequestKind::LeaseRenew || q.kind == shm::RequestKind::LeaseRelease,
              "only lease operations stay off the wire");
        check(a.drive < b.drives.size(), "a lease operation on no drive");
        return;
    }
    check(rtu::encode_request(a.request).has_value(), "admitted a request that does not encode");
    if (q.kind == shm::RequestKind::Probe) {
        check(a.request.address == q.address && q.address >= 1 && q.address <= 247, "a probe to its address");
        check(a.request.pdu == rtu::Request(rtu::ReadHoldingRegisters{q.start, 1}), "a probe reads one word");
        return;
    }
    if (q.kind == shm::RequestKind::Broadcast) {
        check(a.drive == ipc::kBroadcast && a.request.address == 0, "a broadcast goes to address 0");
    } else {
        check(a.drive < b.drives.size(), "admitted for no drive");
        const auto& d = b.drives[a.drive];
        check(a.request.address == d.address, "sent to another address than the drive's");
        const auto name = shm::view(q.drive);
        check(name.empty() ? q.address == d.address : name == d.name, "admitted for another drive than named");
        check(rtu::validate_request(a.request, master::limits_of(*d.profile)).has_value(),
              "admitted beyond the profile's function limits");
    }
    const auto function = static_cast<std::uint8_t>(rtu::function_of(a.request.pdu));
    const auto for_each_profile = [&](auto&& f) {
        if (a.drive == ipc::kBroadcast) {
            for (const auto& d : b.drives) {
                check(
                    std::ranges::find(d.profile->functions.broadcast, function) != d.profile->functions.broadcast.end(),
                    "a broadcast a drive does not take");
                f(*d.profile);
            }
        } else {
            f(*b.drives[a.drive].profile);
        }
    };
    switch (q.kind) {
    case shm::RequestKind::Read:
        check(a.request.pdu == rtu::Request(rtu::ReadHoldingRegisters{q.start, q.count}), "a read as asked");
        for_each_profile([&](const Profile& p) { check_registers(p, 3, q.start, q.count, nullptr); });
        break;
    case shm::RequestKind::Write:
    case shm::RequestKind::Broadcast: {
        check(q.count >= 1 && q.count <= shm::kMaxWriteWords, "a write of 1-123 words");
        check(q.function == 0 || q.function == function, "a write with the function asked");
        if (const auto* one = std::get_if<rtu::WriteSingleRegister>(&a.request.pdu)) {
            check(q.count == 1 && one->address == q.start && one->value == q.values[0], "an FC06 as asked");
        } else {
            const auto* many = std::get_if<rtu::WriteMultipleRegisters>(&a.request.pdu);
            check(many != nullptr && many->start == q.start && many->values.size() == q.count &&
                      std::ranges::equal(many->values.words(), std::span(q.values.data(), q.count)),
                  "an FC16 as asked");
        }
        for_each_profile([&](const Profile& p) { check_registers(p, function, q.start, q.count, q.values.data()); });
        break;
    }
    case shm::RequestKind::Identify:
        check(std::holds_alternative<rtu::ReadDeviceIdentification>(a.request.pdu), "an identify is FC43/14");
        break;
    default: fuzz::fail("admitted an unknown kind");
    }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    // The chunk as the client left it: the input's bytes, zeros after them.
    shm::Request q;
    std::memset(&q, 0, sizeof q);
    std::memcpy(&q, data, std::min(size, sizeof q));

    const auto admitted = ipc::admit(bus(), q);
    if (!admitted) {
        check(admitted.error().reason != shm::RejectReason::None, "a rejection without a reason");
        check(!admitted.error().why.empty(), "a rejection without a line for the log");
        return 0;
    }
    check(shm::compatible(q), "admitted a request of another layout");
    check_admitted(q, *admitted);
    return 0;
}
