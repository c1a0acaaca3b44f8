// SPDX-License-Identifier: Apache-2.0
// What the binding's files share: libdrivebus's errors as Python exceptions, Python callables
// that libdrivebus may call and destroy with or without the GIL, and register arguments given
// by name or number.
#pragma once

#include <pybind11/pybind11.h>

#include <expected>
#include <memory>
#include <optional>
#include <string>
#include <utility>

#include "drivebus/altivar.hpp"
#include "drivebus/client.hpp"

namespace drivebus::python {

namespace py = pybind11;

// Makes DrivebusError and its subclasses, one per ErrorKind, in `module`.
void define_errors(py::module_& module);
// The Python exception for `error`: its class by kind, its message, and the fields
// (kind, exception_code, reason, lease_holder, lease_holder_pid) as attributes.
[[nodiscard]] py::object exception_of(const Error& error);
// Raises exception_of(error) in Python.
[[noreturn]] void raise(const Error& error);
// Raises an error found on this side (InvalidArgument, Unsupported) with `message`.
[[noreturn]] void raise(ErrorKind kind, std::string message);

template <typename T>
T value_or_raise(std::expected<T, Error>&& result) {
    if (!result) {
        raise(result.error());
    }
    if constexpr (!std::is_void_v<T>) {
        return std::move(*result);
    }
}

// Runs a libdrivebus call with the GIL released (it may wait), then raises its error in Python.
template <typename F>
auto blocking(F&& call) {
    using Result = decltype(call());
    std::optional<Result> result;
    {
        const py::gil_scoped_release release;
        result.emplace(call());
    }
    return value_or_raise(std::move(*result));
}

// A Python callable held by libdrivebus: called with the GIL taken (libdrivebus calls it from
// dispatch(), which the caller may run with the GIL released, as the blocking calls do), and
// destroyed with it taken too, whoever drops the last copy. An exception it raises cannot cross
// libdrivebus: it goes to sys.unraisablehook.
class Callback {
public:
    explicit Callback(py::object function)
        : function_(new py::object(std::move(function)), [](py::object* f) {
              const py::gil_scoped_acquire gil;
              delete f;
          }) {}

    template <typename... Args>
    void operator()(Args&&... args) const {
        const py::gil_scoped_acquire gil;
        try {
            (*function_)(std::forward<Args>(args)...);
        } catch (py::error_already_set& e) {
            e.discard_as_unraisable("a drivebus callback");
        }
    }

private:
    std::shared_ptr<py::object> function_;
};

// A register by name ("FA01") or number (0xFA01, "0xFA01", "64001"), resolved through the drive.
[[nodiscard]] std::uint16_t register_of(const Drive& drive, const py::object& reg);

void define_bus(py::module_& module);
void define_drive(py::module_& module);

}  // namespace drivebus::python
