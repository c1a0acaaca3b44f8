// SPDX-License-Identifier: Apache-2.0
// drivebus.Bus: a bus of drivebusd, its status, its drives, its descriptor for an event loop.
#include <pybind11/stl.h>

#include <string>
#include <vector>

#include "common.hpp"
#include "values.hpp"

namespace drivebus::python {

void define_bus(py::module_& m) {
    py::class_<Bus>(m, "Bus", R"(A bus of the running drivebusd.

Its callbacks and asynchronous requests complete in dispatch(), on the thread that calls it:
call dispatch() whenever descriptor() is readable (drivebus.aio does so on an asyncio loop).
Blocking calls dispatch while they wait, with the GIL released. A Bus belongs to one thread.)")
        .def_static(
            "connect",
            [](const std::string& name, const std::string& application, double request_timeout,
               std::optional<std::string> profile_dir) {
                ConnectOptions options;
                options.application = application;
                options.delivery = Delivery::Dispatch;
                options.request_timeout = milliseconds_of(request_timeout, "request_timeout");
                if (profile_dir) {
                    options.profile_dir = *profile_dir;
                }
                return blocking([&] { return Bus::connect(name, options); });
            },
            py::arg("name") = "", py::arg("application") = "python", py::arg("request_timeout") = 2.0,
            py::arg("profile_dir") = py::none(),
            "Connects to the bus `name` (empty: the only one announced). NotRunning when no drivebusd "
            "runs, NoSuchBus when it does not announce that bus. request_timeout: seconds a request may "
            "take, queueing included.")
        .def_static(
            "list",
            []() {
                ConnectOptions options;
                options.delivery = Delivery::Dispatch;
                return blocking([&] { return Bus::list(options); });
            },
            "The names of the buses drivebusd announces.")
        .def_property_readonly("name", &Bus::name)
        .def(
            "status",
            [](const Bus& bus, double wait) {
                const auto w = milliseconds_of(wait, "wait");
                return status_dict(blocking([&] { return bus.status(w); }), bus.daemon_alive());
            },
            py::arg("wait") = 0.0,
            "The latest bus status as a dict (waits up to `wait` seconds for the first): line, counters, "
            "drives with their health.")
        .def(
            "daemon_alive",
            [](const Bus& bus) {
                (void)bus.dispatch();  // the statuses that came since: a script may not have dispatched
                return bus.daemon_alive();
            },
            "False once drivebusd has been silent for 3 s.")
        .def("can_request", &Bus::can_request,
             "Whether this process may send requests (a member of the bus's control group).")
        .def_property_readonly("client_id", &Bus::client_id)
        .def(
            "drive", [](const Bus& bus, const std::string& name) { return value_or_raise(bus.drive(name)); },
            py::arg("name"), "The drive by name, or by address (\"3\").")
        .def(
            "drives",
            [](const Bus& bus) {
                const auto s = blocking([&] { return bus.status(Milliseconds(2000)); });
                std::vector<Drive> drives;
                for (std::size_t i = 0; i < s.drive_count && i < s.drives.size(); ++i) {
                    drives.push_back(value_or_raise(bus.drive(shm::view(s.drives[i].name))));
                }
                return drives;
            },
            "Every drive of the bus, in drivebusd's order.")
        .def(
            "broadcast",
            [](const Bus& bus, std::uint16_t address, const std::vector<std::uint16_t>& values) {
                blocking([&] { return bus.broadcast(address, values); });
            },
            py::arg("address"), py::arg("values"),
            "Writes `values` at `address` to every drive (Modbus address 0): no reply.")
        .def("descriptor", &Bus::descriptor,
             "The descriptor to watch for reading; when it is readable, call dispatch().")
        .def(
            "dispatch", [](const Bus& bus) { return bus.dispatch(); },
            "Runs the callbacks for what has arrived (snapshots, answers); never waits. Returns how many ran.")
        .def("__repr__", [](const Bus& bus) { return "<drivebus.Bus '" + bus.name() + "'>"; });
}

}  // namespace drivebus::python
