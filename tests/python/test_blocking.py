# SPDX-License-Identifier: Apache-2.0
"""The blocking API against drivebusd and drivebus-sim: values checked against the simulator's
own, writes in its write log, errors by kind, the lease and its fallback."""
import os
import signal
import subprocess
import sys
import textwrap

import pytest

import drivebus
from conftest import RUN_FORWARD, STOP, wait_until


def test_the_bus_lists_its_drives_and_its_status(bus, bus_name):
    assert bus_name in drivebus.Bus.list()
    status = bus.status(2.0)
    assert status["bus"] == bus_name
    assert status["drivebusd"] == "running"
    assert [d["name"] for d in status["drives"]] == ["pump", "fan"]
    assert [d.name for d in bus.drives()] == ["pump", "fan"]
    assert bus.drive("pump").address == 1
    assert bus.drive("2").name == "fan"


def test_snapshot_values_are_the_simulators(pump, sim):
    sim.command("set 1 FA01 4321")  # the reference: polled every 200 ms
    snap = wait_until(lambda: (s := pump.snapshot(1.0)).raw("FA01") == 4321 and s, 10, "FA01 = 4321 polled")
    assert snap.value("FA01") == pytest.approx(43.21)
    assert snap.registers["FA01"] == 4321
    assert snap.raw(0xFA01) == 4321 and snap.raw("0xFA01") == 4321
    assert snap.registers["FD01"] == sim.register(1, "FD01")  # the status word, steady while stopped
    assert snap.health == "online"
    assert snap.drive == "pump"
    assert snap.time_ns("FA01") > 0
    # The next snapshot is newer.
    assert pump.snapshot(2.0, after=snap.sequence).sequence > snap.sequence


def test_a_read_goes_to_the_drive(pump, sim):
    sim.command("set 1 F803 7")
    assert pump.read("F803") == [7]
    assert pump.read(0xFD01) == [sim.register(1, "FD01")]
    assert pump.read_value("FA01") == pytest.approx(sim.register(1, "FA01") / 100)


def test_writes_land_in_the_drives_write_log(pump, sim):
    pump.write_value("FA01", 37.5)
    assert sim.register(1, "FA01") == 3750
    pump.write(0xFA01, 2500)
    assert (0xFA01, 3750) in sim.writes(1) and (0xFA01, 2500) in sim.writes(1)
    assert pump.holds_control()


def test_altivar_typed_commands_and_state(pump, sim):
    atv = drivebus.Altivar(pump)
    atv.set_frequency(30.0)
    atv.run_forward()
    assert sim.register(1, "FA00") == RUN_FORWARD
    assert sim.register(1, "FA01") == 3000
    state = wait_until(lambda: (s := atv.state())["running"] and s, 10, "the pump running")
    assert state["output_hz"] is not None
    assert state["lease"]["state"] == "held"
    atv.stop()
    assert sim.register(1, "FA00") == STOP


def test_errors_come_by_kind_with_libdrivebus_words(bus, pump):
    with pytest.raises(drivebus.InvalidArgument) as unknown:
        pump.read("ZZ99")
    assert isinstance(unknown.value, ValueError) and "ZZ99" in str(unknown.value)
    assert unknown.value.kind == "invalid argument"
    with pytest.raises(drivebus.NoSuchBus):
        drivebus.Bus.connect("no-such-bus")
    with pytest.raises(drivebus.InvalidArgument):
        pump.write_value("FA01", 5000.0)  # above the profile's maximum
    with pytest.raises(drivebus.InvalidArgument):
        pump.snapshot(wait=-1)
    with pytest.raises(drivebus.DrivebusError) as exception:
        bus.drive("fan").read(0x0001, 1)  # the ATV58 holds no register 1
    assert isinstance(exception.value, (drivebus.ModbusException, drivebus.Rejected)), exception.value
    if isinstance(exception.value, drivebus.ModbusException):
        assert exception.value.exception_code == 2


HOLDER = textwrap.dedent("""
    import sys, time, drivebus
    pump = drivebus.Bus.connect(sys.argv[1], application="holder").drive("pump")
    atv = drivebus.Altivar(pump)
    atv.set_frequency(20.0)
    atv.run_forward()
    print("holding", flush=True)
    while True:
        pump.keep_alive()
        time.sleep(0.2)
""")


def test_a_killed_lease_holder_lets_the_drive_fall_back(bus_name, pump, sim):
    holder = subprocess.Popen([sys.executable, "-c", HOLDER, bus_name], stdin=subprocess.DEVNULL,
                              stdout=subprocess.PIPE, env=os.environ)
    try:
        assert holder.stdout.readline().strip() == b"holding"
        assert sim.register(1, "FA00") == RUN_FORWARD
        # Another client is refused while the holder lives, and told who holds it.
        with pytest.raises(drivebus.NotPermitted) as refused:
            pump.write_value("FA01", 10.0)
        assert refused.value.lease_holder.startswith("holder") and refused.value.lease_holder_pid == holder.pid
        os.kill(holder.pid, signal.SIGKILL)
        holder.wait()
        # The lease (1 s) runs out without the holder's renewals: drivebusd writes the ramp stop.
        wait_until(lambda: sim.register(1, "FA00") == STOP, 10, "the pump's fallback (ramp stop)")
        assert wait_until(lambda: pump.snapshot(1.0).lease["state"] in ("expired", "free"), 10, "the lease ended")
    finally:
        holder.kill()
        holder.wait()


def test_the_type_hints_name_what_the_module_has():
    import ast
    import pathlib
    import drivebus._drivebus as native
    stub = ast.parse((pathlib.Path(native.__file__).parent / "_drivebus.pyi").read_text())
    classes = {n.name: n for n in stub.body if isinstance(n, ast.ClassDef)}
    public = {name for name in dir(native) if not name.startswith("_")}
    assert set(classes) == public
    for name, node in classes.items():
        hinted = {f.name for f in node.body if isinstance(f, ast.FunctionDef) and not f.name.startswith("__")}
        members = {m for m in dir(getattr(native, name)) if not m.startswith("_")}
        if issubclass(getattr(native, name), BaseException):
            continue  # the exceptions' attributes are set on each instance
        assert hinted == members, f"{name}: hinted only {hinted - members}, not hinted {members - hinted}"
