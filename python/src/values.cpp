// SPDX-License-Identifier: Apache-2.0
#include "values.hpp"

#include <pybind11/stl.h>

#include <cmath>
#include <string>

namespace drivebus::python {
namespace {

std::string str(std::string_view s) {
    return std::string(s);
}

template <std::size_t N>
std::string str(const std::array<char, N>& text) {
    return std::string(shm::view(text));
}

// The register's name in the profile, or "0xFA01".
std::string name_of(const Drive& drive, std::uint16_t address) {
    if (const auto* info = drive.info(address); info != nullptr && !info->name.empty()) {
        return info->name;
    }
    char text[8];
    std::snprintf(text, sizeof text, "0x%04X", static_cast<unsigned>(address));
    return text;
}

const shm::RegisterSample* sample_of(const Snapshot& s, const py::object& reg) {
    const auto* sample = s.data.find(register_of(s.drive, reg));
    return sample != nullptr && sample->valid != 0 ? sample : nullptr;
}

}  // namespace

Milliseconds milliseconds_of(double seconds, std::string_view what) {
    if (!std::isfinite(seconds) || seconds < 0 || seconds > 86400.0 * 365) {
        raise(ErrorKind::InvalidArgument,
              std::string(what) + " must be a number of seconds from 0, not " + std::to_string(seconds));
    }
    return Milliseconds(static_cast<Milliseconds::rep>(std::llround(seconds * 1000.0)));
}

py::dict lease_dict(const shm::LeaseStatus& lease) {
    py::dict d;
    d["state"] = str(to_string(lease.state));
    d["holder"] = str(lease.holder);
    d["holder_pid"] = lease.holder_pid;
    d["duration"] = lease.duration_ms / 1000.0;
    d["fallback"] = str(to_string(lease.fallback));
    d["fallback_ok"] = lease.fallback_ok != 0;
    d["expiries"] = lease.expiries;
    return d;
}

py::dict status_dict(const shm::BusStatus& s, bool daemon_alive) {
    py::dict d;
    d["bus"] = str(s.bus);
    d["drivebusd"] = daemon_alive ? "running" : "silent";
    d["pid"] = s.daemon_pid;
    d["up"] = s.up != 0;
    d["device"] = str(s.device);
    d["baud"] = s.baud;
    d["format"] = str(s.format);
    d["drives_online"] = s.drives_online;
    py::list drives;
    for (std::size_t i = 0; i < s.drive_count && i < s.drives.size(); ++i) {
        const auto& e = s.drives[i];
        py::dict drive;
        drive["name"] = str(e.name);
        drive["address"] = e.address;
        drive["profile"] = str(e.profile);
        drive["health"] = str(to_string(e.health));
        drives.append(drive);
    }
    d["drives"] = drives;
    py::dict counters;
    counters["transmissions"] = s.counters.transmissions;
    counters["replies"] = s.counters.replies;
    counters["timeouts"] = s.counters.timeouts;
    d["counters"] = counters;
    return d;
}

py::dict state_dict(const DriveState& st) {
    py::dict d;
    d["sequence"] = st.sequence;
    d["health"] = str(to_string(st.health));
    d["status_word"] = st.status_word ? py::object(py::int_(*st.status_word)) : py::none();
    d["running"] = st.running;
    d["reverse"] = st.reverse;
    d["fault"] = st.fault;
    d["alarm"] = st.alarm;
    d["ready"] = st.ready;
    d["flags"] = st.flags;
    d["output_hz"] = st.output_hz ? py::object(py::float_(*st.output_hz)) : py::none();
    d["fault_code"] = st.fault_code ? py::object(py::int_(*st.fault_code)) : py::none();
    d["fault_name"] = st.fault_name;
    d["fault_title"] = st.fault_title;
    d["alarms"] = st.alarms;
    d["lease"] = lease_dict(st.lease);
    return d;
}

void define_snapshot(py::module_& m) {
    py::class_<Snapshot>(m, "Snapshot", R"(A drive's registers as drivebusd last polled them, with no line time.

Registers are named as the drive's profile names them ("FD00"), or "0xFA01" when it has no name
for them; a register whose last read failed is left out of `registers` and gives None.)")
        .def_property_readonly("drive", [](const Snapshot& s) { return s.drive.name(); })
        .def_property_readonly("sequence", [](const Snapshot& s) { return s.data.sequence; })
        .def_property_readonly(
            "published_ns", [](const Snapshot& s) { return s.data.published_ns; },
            "When drivebusd published it (CLOCK_MONOTONIC, time.monotonic_ns()).")
        .def_property_readonly("health", [](const Snapshot& s) { return str(to_string(s.data.health)); })
        .def_property_readonly("lease", [](const Snapshot& s) { return lease_dict(s.data.lease); })
        .def_property_readonly(
            "registers",
            [](const Snapshot& s) {
                py::dict d;
                for (std::size_t i = 0; i < s.data.register_count && i < s.data.registers.size(); ++i) {
                    const auto& r = s.data.registers[i];
                    if (r.valid != 0) {
                        d[py::str(name_of(s.drive, r.address))] = r.value;
                    }
                }
                return d;
            },
            "Every valid register's raw word, by name.")
        .def(
            "raw",
            [](const Snapshot& s, const py::object& reg) -> py::object {
                const auto* sample = sample_of(s, reg);
                return sample != nullptr ? py::object(py::int_(sample->value)) : py::none();
            },
            py::arg("register"), "The raw word of a register (by name or number), None when not valid.")
        .def(
            "value",
            [](const Snapshot& s, const py::object& reg) -> py::object {
                const auto* sample = sample_of(s, reg);
                if (sample == nullptr) {
                    return py::none();
                }
                const auto* info = s.drive.info(sample->address);
                return py::float_(info != nullptr ? info->to_engineering(sample->value) : sample->value);
            },
            py::arg("register"),
            "The engineering value of a register (the profile's sign and scale: FD00 6000 -> 60.0 Hz), "
            "None when not valid.")
        .def(
            "time_ns",
            [](const Snapshot& s, const py::object& reg) -> py::object {
                const auto* sample = sample_of(s, reg);
                return sample != nullptr ? py::object(py::int_(sample->time_ns)) : py::none();
            },
            py::arg("register"), "When the reply carrying the register's value ended (CLOCK_MONOTONIC).")
        .def(
            "state",
            [](const Snapshot& s) {
                if (s.drive.profile() == nullptr) {
                    raise(ErrorKind::Unsupported, "drive '" + s.drive.name() + "': no profile");
                }
                return state_dict(decode_state(*s.drive.profile(), s.data));
            },
            "The Altivar state decoded from it (running, fault, output_hz, ...), as a dict.")
        .def("__repr__", [](const Snapshot& s) {
            return "<drivebus.Snapshot " + s.drive.name() + " #" + std::to_string(s.data.sequence) + " " +
                   str(to_string(s.data.health)) + ">";
        });
}

}  // namespace drivebus::python
