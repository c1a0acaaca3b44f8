# SPDX-License-Identifier: Apache-2.0
"""drivebus: drives on a Modbus RTU line owned by drivebusd, from Python.

The blocking API, for scripts::

    import drivebus
    bus = drivebus.Bus.connect("line1")
    pump = bus.drive("pump")
    print(pump.snapshot().value("FD00"), "Hz")   # as drivebusd last polled it: no line time
    pump.write_value("FA01", 40.0)               # takes the control lease
    drivebus.Altivar(pump).run_forward()

For asyncio, drivebus.aio: the same on the running loop, with no thread of its own.
Every libdrivebus error is a DrivebusError subclass named for its kind (Timeout, NotPermitted,
ModbusException, ...). See docs/python.md.
"""
from ._drivebus import (  # noqa: F401
    __version__,
    Altivar,
    BadFrame,
    Bus,
    BusDown,
    DaemonGone,
    Drive,
    DrivebusError,
    Expired,
    InvalidArgument,
    LateReply,
    ModbusException,
    NoReply,
    NoSuchBus,
    NotPermitted,
    NotRunning,
    OutcomeUnknown,
    QueueFull,
    Rejected,
    Snapshot,
    Subscription,
    Timeout,
    Unsupported,
    Withdrawn,
)

__all__ = [
    "Altivar", "BadFrame", "Bus", "BusDown", "DaemonGone", "Drive", "DrivebusError", "Expired",
    "InvalidArgument", "LateReply", "ModbusException", "NoReply", "NoSuchBus", "NotPermitted",
    "NotRunning", "OutcomeUnknown", "QueueFull", "Rejected", "Snapshot", "Subscription", "Timeout",
    "Unsupported", "Withdrawn",
]
