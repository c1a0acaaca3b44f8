// SPDX-License-Identifier: Apache-2.0
// The drivebus Python module's native part, `drivebus._drivebus`: libdrivebus on
// Delivery::Dispatch, so that the library starts no thread. Blocking calls release the GIL
// while they wait; the asynchronous ones complete by callback in Bus.dispatch(), which the
// Python package (drivebus/__init__.py) runs from the asyncio loop's reader on Bus.descriptor().
#include <map>
#include <string>

#include "common.hpp"
#include "drivebus/version.hpp"

namespace drivebus::python {
namespace {

// The classes, kept for the module's life (a module's attributes could be replaced by anyone).
std::map<ErrorKind, py::object>& classes() {
    static auto* by_kind = new std::map<ErrorKind, py::object>();  // never destroyed: outlives the interpreter's end
    return *by_kind;
}

struct Kind {
    ErrorKind kind;
    const char* name;
    const char* doc;
    PyObject* also;  // a built-in exception it also is, or null
};

}  // namespace

void define_errors(py::module_& module) {
    static py::exception<std::exception> base(module, "DrivebusError");
    base.doc() =
        "A libdrivebus error. `kind` names it as libdrivebus does (\"timeout\", \"not_permitted\", ...); "
        "each kind has its own subclass.";
    const Kind kinds[] = {
        {ErrorKind::Exception, "ModbusException", "The drive answered with a Modbus exception (exception_code).",
         nullptr},
        {ErrorKind::Timeout, "Timeout", "The drive did not answer.", PyExc_TimeoutError},
        {ErrorKind::BadFrame, "BadFrame", "The reply was spoiled (CRC, framing, parity, echo).", nullptr},
        {ErrorKind::Rejected, "Rejected", "drivebusd refused the request before the bus (reason).", nullptr},
        {ErrorKind::QueueFull, "QueueFull", "The bus's queue is full: retry later.", nullptr},
        {ErrorKind::BusDown, "BusDown", "The bus's line is not open.", nullptr},
        {ErrorKind::NotPermitted, "NotPermitted",
         "Another client holds the control lease (lease_holder), or this process is not in the control group.",
         PyExc_PermissionError},
        {ErrorKind::NotRunning, "NotRunning", "No drivebusd to connect to.", PyExc_ConnectionError},
        {ErrorKind::NoSuchBus, "NoSuchBus", "drivebusd runs but does not announce that bus.", PyExc_LookupError},
        {ErrorKind::DaemonGone, "DaemonGone", "drivebusd went silent after the connection.", PyExc_ConnectionError},
        {ErrorKind::NoReply, "NoReply",
         "drivebusd answered neither the request in time nor its withdrawal: a write may have been applied.",
         PyExc_TimeoutError},
        {ErrorKind::InvalidArgument, "InvalidArgument", "Bad input on this side: unknown register, value too large.",
         PyExc_ValueError},
        {ErrorKind::Unsupported, "Unsupported", "The drive's profile does not define what was asked.", nullptr},
        {ErrorKind::LateReply, "LateReply", "The drive answered only after the response time-out.", nullptr},
        {ErrorKind::Withdrawn, "Withdrawn", "Not answered in time and withdrawn before the wire: never sent.",
         PyExc_TimeoutError},
        {ErrorKind::OutcomeUnknown, "OutcomeUnknown",
         "Not answered in time after it reached the wire: a write may have been applied.", PyExc_TimeoutError},
        {ErrorKind::Expired, "Expired", "Its deadline passed before it reached the wire: never sent.", nullptr},
    };
    const auto type = py::module_::import("builtins").attr("type");
    for (const auto& k : kinds) {
        py::tuple bases = k.also != nullptr ? py::make_tuple(base, py::handle(k.also)) : py::make_tuple(base);
        py::dict body;
        body["__doc__"] = k.doc;
        body["__module__"] = "drivebus";
        py::object cls = type(k.name, bases, body);
        module.attr(k.name) = cls;
        classes()[k.kind] = cls;
    }
}

py::object exception_of(const Error& error) {
    py::object e = classes().at(error.kind)(error.message);
    e.attr("kind") = std::string(to_string(error.kind));
    e.attr("exception_code") = error.kind == ErrorKind::Exception ? py::object(py::int_(error.exception)) : py::none();
    e.attr("reason") = error.reason != shm::RejectReason::None
                           ? py::object(py::str(std::string(to_string(error.reason))))
                           : py::none();
    e.attr("lease_holder") =
        error.lease_holder.empty() ? py::object(py::none()) : py::object(py::str(error.lease_holder));
    e.attr("lease_holder_pid") = error.lease_holder_pid;
    return e;
}

void raise(ErrorKind kind, std::string message) {
    Error error;
    error.kind = kind;
    error.message = std::move(message);
    raise(error);
}

void raise(const Error& error) {
    const py::object e = exception_of(error);
    PyErr_SetObject(reinterpret_cast<PyObject*>(Py_TYPE(e.ptr())), e.ptr());
    throw py::error_already_set();
}

std::uint16_t register_of(const Drive& drive, const py::object& reg) {
    if (py::isinstance<py::int_>(reg)) {
        const auto n = reg.cast<long long>();
        if (n < 0 || n > 0xFFFF) {
            raise(ErrorKind::InvalidArgument, "register " + std::to_string(n) + " is outside 0..65535");
        }
        return static_cast<std::uint16_t>(n);
    }
    return value_or_raise(drive.resolve(reg.cast<std::string>()));
}

}  // namespace drivebus::python

PYBIND11_MODULE(_drivebus, m) {
    using namespace drivebus::python;
    m.doc() = "libdrivebus for Python: drives on a Modbus RTU line owned by drivebusd.";
    m.attr("__version__") = DRIVEBUS_VERSION_STRING;
    define_errors(m);
    define_bus(m);
    define_drive(m);
}
