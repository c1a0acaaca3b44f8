// SPDX-License-Identifier: Apache-2.0
// drivebus.Drive and drivebus.Altivar: requests, snapshots, the control lease, typed commands;
// each request blocking (the GIL released while it waits) or completed by callback in
// Bus.dispatch() (the *_async methods drivebus.aio builds its coroutines on).
#include <pybind11/functional.h>
#include <pybind11/stl.h>

#include <string>
#include <vector>

#include "common.hpp"
#include "values.hpp"

namespace drivebus::python {
namespace {

WriteOptions write_options(bool take_over, std::optional<double> deadline) {
    WriteOptions options;
    options.take_over = take_over;
    if (deadline) {
        options.deadline = milliseconds_of(*deadline, "deadline");
    }
    return options;
}

// One word or a sequence of them.
std::vector<std::uint16_t> words_of(const py::object& values) {
    if (py::isinstance<py::int_>(values)) {
        return {values.cast<std::uint16_t>()};
    }
    return values.cast<std::vector<std::uint16_t>>();
}

// A completion for a request with no value: callback(None) or callback(error).
Drive::Done done_with(py::object callback) {
    return [cb = Callback(std::move(callback))](const std::expected<void, Error>& r) {
        const py::gil_scoped_acquire gil;
        cb(r ? py::object(py::none()) : exception_of(r.error()));
    };
}

// The word for an engineering value of a register, as its profile converts and bounds it.
std::uint16_t word_for(const Drive& drive, std::uint16_t address, double value) {
    const auto* info = drive.info(address);
    if (info == nullptr) {
        raise(ErrorKind::InvalidArgument, "drive '" + drive.name() + "': register " + std::to_string(address) +
                                              " is not in its profile: write a raw word instead");
    }
    const auto raw = info->from_engineering(value);
    if (!raw || !info->in_range(*raw)) {
        raise(ErrorKind::InvalidArgument, "drive '" + drive.name() + "': " + std::to_string(value) + " " + info->unit +
                                              " is outside what " + info->name + " takes");
    }
    return *raw;
}

py::object info_of(const Drive& drive, std::uint16_t address) {
    const auto* info = drive.info(address);
    if (info == nullptr) {
        return py::none();
    }
    py::dict d;
    d["name"] = info->name;
    d["address"] = address;
    d["title"] = info->title;
    d["unit"] = info->unit;
    d["scale"] = info->scale;
    d["min"] = info->min ? py::object(py::int_(*info->min)) : py::none();
    d["max"] = info->max ? py::object(py::int_(*info->max)) : py::none();
    d["signed"] = info->is_signed;
    d["readable"] = readable(info->access);
    d["writable"] = writable(info->access);
    return d;
}

void define_altivar(py::module_& m) {
    using Call = std::expected<void, Error> (Altivar::*)(WriteOptions) const;
    using AsyncCall = void (Altivar::*)(Drive::Done, WriteOptions) const;
    py::class_<Altivar> altivar(m, "Altivar",
                                R"(An Altivar drive's typed commands, from its profile's [control] section.

A write to the command word or the reference takes the drive's control lease; keep it with
drive.keep_alive() from the control loop itself.)");
    altivar.def(py::init<Drive>(), py::arg("drive"))
        .def_property_readonly("drive", &Altivar::drive)
        .def(
            "set_frequency",
            [](const Altivar& a, double hz, bool take_over, std::optional<double> deadline) {
                const auto options = write_options(take_over, deadline);
                blocking([&] { return a.set_frequency(hz, options); });
            },
            py::arg("hz"), py::kw_only(), py::arg("take_over") = false, py::arg("deadline") = py::none(),
            "Writes the frequency reference in Hz (the profile's scale and range).")
        .def(
            "set_frequency_async",
            [](const Altivar& a, double hz, py::object callback, bool take_over, std::optional<double> deadline) {
                a.async_set_frequency(hz, done_with(std::move(callback)), write_options(take_over, deadline));
            },
            py::arg("hz"), py::arg("callback"), py::kw_only(), py::arg("take_over") = false,
            py::arg("deadline") = py::none())
        .def(
            "state",
            [](const Altivar& a, double wait) {
                const auto w = milliseconds_of(wait, "wait");
                return state_dict(blocking([&] { return a.state(w); }));
            },
            py::arg("wait") = 1.0, "The latest snapshot decoded: running, reverse, fault, output_hz, alarms, lease.");
    const std::pair<const char*, std::pair<Call, AsyncCall>> commands[] = {
        {"run_forward", {&Altivar::run_forward, &Altivar::async_run_forward}},
        {"run_reverse", {&Altivar::run_reverse, &Altivar::async_run_reverse}},
        {"stop", {&Altivar::stop, &Altivar::async_stop}},
        {"freewheel", {&Altivar::freewheel, &Altivar::async_freewheel}},
        {"reset_fault", {&Altivar::reset_fault, &Altivar::async_reset_fault}},
    };
    for (const auto& [name, calls] : commands) {
        const auto [call, async_call] = calls;
        altivar.def(
            name,
            [call](const Altivar& a, bool take_over, std::optional<double> deadline) {
                const auto options = write_options(take_over, deadline);
                blocking([&] { return (a.*call)(options); });
            },
            py::kw_only(), py::arg("take_over") = false, py::arg("deadline") = py::none(),
            "Writes the profile's command word for it (ramp stop for stop(), coast for freewheel()).");
        altivar.def(
            (std::string(name) + "_async").c_str(),
            [async_call](const Altivar& a, py::object callback, bool take_over, std::optional<double> deadline) {
                (a.*async_call)(done_with(std::move(callback)), write_options(take_over, deadline));
            },
            py::arg("callback"), py::kw_only(), py::arg("take_over") = false, py::arg("deadline") = py::none());
    }
}

}  // namespace

void define_drive(py::module_& m) {
    define_snapshot(m);
    py::class_<Subscription>(m, "Subscription", "Calls its callback until cancelled (or collected).")
        .def("cancel", &Subscription::reset, "Stops the callbacks; none runs once this has returned.")
        .def("__enter__", [](Subscription& s) -> Subscription& { return s; })
        .def("__exit__", [](Subscription& s, const py::args&) { s.reset(); });

    py::class_<Drive>(m, "Drive", "A drive on a bus: requests on the line, its snapshots, its control lease.")
        .def_property_readonly("name", &Drive::name)
        .def_property_readonly("address", &Drive::address)
        .def_property_readonly(
            "profile",
            [](const Drive& d) -> py::object {
                return d.profile() != nullptr ? py::object(py::str(d.profile()->type)) : py::none();
            },
            "The profile's type (\"atv21\"), None when drivebusd named none this process could load.")
        .def(
            "resolve", [](const Drive& d, const py::object& reg) { return register_of(d, reg); }, py::arg("register"),
            "A register's number from its name (\"FA01\") or number (\"0xFA01\", 64001).")
        .def(
            "info", [](const Drive& d, const py::object& reg) { return info_of(d, register_of(d, reg)); },
            py::arg("register"), "What the profile says of a register (unit, scale, range, access), or None.")
        .def(
            "read",
            [](const Drive& d, const py::object& reg, std::uint16_t count) {
                const auto address = register_of(d, reg);
                return blocking([&] { return d.read(address, count); });
            },
            py::arg("register"), py::arg("count") = 1,
            "Reads `count` raw words from the drive (FC03), on the line now.")
        .def(
            "read_value",
            [](const Drive& d, const py::object& reg) {
                const auto address = register_of(d, reg);
                const auto words = blocking([&] { return d.read(address, 1); });
                const auto* info = d.info(address);
                return info != nullptr ? info->to_engineering(words.at(0)) : static_cast<double>(words.at(0));
            },
            py::arg("register"), "Reads one register from the drive, as its engineering value.")
        .def(
            "write",
            [](const Drive& d, const py::object& reg, const py::object& values, bool take_over,
               std::optional<double> deadline) {
                const auto address = register_of(d, reg);
                const auto words = words_of(values);
                const auto options = write_options(take_over, deadline);
                blocking([&] { return d.write(address, words, options); });
            },
            py::arg("register"), py::arg("values"), py::kw_only(), py::arg("take_over") = false,
            py::arg("deadline") = py::none(),
            "Writes raw words (FC06 for one, FC16 for more). take_over: take the control lease from another "
            "client; deadline: seconds within which it must reach the wire, or never be sent (Expired).")
        .def(
            "write_value",
            [](const Drive& d, const py::object& reg, double value, bool take_over, std::optional<double> deadline) {
                const auto address = register_of(d, reg);
                const std::vector<std::uint16_t> words{word_for(d, address, value)};
                const auto options = write_options(take_over, deadline);
                blocking([&] { return d.write(address, words, options); });
            },
            py::arg("register"), py::arg("value"), py::kw_only(), py::arg("take_over") = false,
            py::arg("deadline") = py::none(),
            "Writes an engineering value (the profile's scale and range: FA01 40.0 -> 4000).")
        .def(
            "identify",
            [](const Drive& d) {
                const auto id = blocking([&] { return d.identify(); });
                py::dict out;
                out["vendor"] = id.vendor;
                out["product_code"] = id.product_code;
                out["revision"] = id.revision;
                return out;
            },
            "The drive's identification (FC43/14): vendor, product_code, revision.")
        .def(
            "snapshot",
            [](const Drive& d, double wait, std::uint64_t after) {
                const auto w = milliseconds_of(wait, "wait");
                return Snapshot{.data = blocking([&] { return d.wait_snapshot(w, after); }), .drive = d};
            },
            py::arg("wait") = 1.0, py::arg("after") = 0,
            "The latest snapshot; waits up to `wait` seconds for one newer than sequence `after`.")
        .def(
            "on_snapshot",
            [](const Drive& d, py::object callback) {
                return d.on_snapshot([cb = Callback(std::move(callback)), d](const shm::DriveSnapshot& s) {
                    cb(Snapshot{.data = s, .drive = d});
                });
            },
            py::arg("callback"), "Calls callback(snapshot) in Bus.dispatch() for each new snapshot.")
        .def(
            "keep_alive", [](const Drive& d) { blocking([&] { return d.keep_alive(); }); },
            "Renews this process's control lease (NotPermitted when it holds none). Call it from the control "
            "loop itself, a few times per lease time: a loop that hangs lets the lease run out, and drivebusd "
            "applies the drive's fallback.")
        .def(
            "release_control", [](const Drive& d) { blocking([&] { return d.release_control(); }); },
            "Gives up the control lease without the fallback.")
        .def("holds_control", &Drive::holds_control,
             "Whether one of this Bus's writes took the lease (it may have run out since).")
        .def(
            "read_async",
            [](const Drive& d, const py::object& reg, std::uint16_t count, py::object callback) {
                d.async_read(register_of(d, reg), count,
                             [cb = Callback(std::move(callback))](std::expected<std::vector<std::uint16_t>, Error> r) {
                                 const py::gil_scoped_acquire gil;
                                 if (r) {
                                     cb(py::cast(*r), py::none());
                                 } else {
                                     cb(py::none(), exception_of(r.error()));
                                 }
                             });
            },
            py::arg("register"), py::arg("count"), py::arg("callback"),
            "Sends a read; callback(words, None) or callback(None, error) in a later Bus.dispatch().")
        .def(
            "write_async",
            [](const Drive& d, const py::object& reg, const py::object& values, py::object callback, bool take_over,
               std::optional<double> deadline) {
                d.async_write(register_of(d, reg), words_of(values), done_with(std::move(callback)),
                              write_options(take_over, deadline));
            },
            py::arg("register"), py::arg("values"), py::arg("callback"), py::kw_only(), py::arg("take_over") = false,
            py::arg("deadline") = py::none(), "Sends a write; callback(None) or callback(error) in a later dispatch.")
        .def(
            "word_for",
            [](const Drive& d, const py::object& reg, double value) { return word_for(d, register_of(d, reg), value); },
            py::arg("register"), py::arg("value"), "The raw word for an engineering value (scale and range checked).")
        .def(
            "keep_alive_async",
            [](const Drive& d, py::object callback) { d.async_keep_alive(done_with(std::move(callback))); },
            py::arg("callback"))
        .def(
            "release_control_async",
            [](const Drive& d, py::object callback) { d.async_release_control(done_with(std::move(callback))); },
            py::arg("callback"))
        .def("__repr__", [](const Drive& d) {
            return "<drivebus.Drive '" + d.name() + "' at " + std::to_string(d.address()) + ">";
        });
    define_altivar(m);
}

}  // namespace drivebus::python
