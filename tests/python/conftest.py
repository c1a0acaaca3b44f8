# SPDX-License-Identifier: Apache-2.0
"""The stack the Python module's tests run against: drivebusd and drivebus-sim started by the
GoogleTest that runs pytest (tests/python/pytest_test.cpp), named by the environment:
DRIVEBUS_TEST_BUS (the bus), DRIVEBUS_TEST_SIM_CONTROL (the simulator's control socket).
On the bus: an ATV21 "pump" at address 1 (lease 1 s, fallback a ramp stop) and an ATV58 "fan" at 2."""
import os
import socket
import time

import pytest

import drivebus

RUN_FORWARD = 0xC400  # profiles/atv21.toml [control]
STOP = 0xC000


def _env(name):
    value = os.environ.get(name)
    if not value:
        pytest.fail(f"{name} is not set: run these tests through ctest (tests/python/pytest_test.cpp)")
    return value


class Sim:
    """drivebus-sim's control socket: one line in, one line back."""

    def __init__(self, path):
        self.path = path

    def command(self, line):
        with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as s:
            s.settimeout(5)
            s.connect(self.path)
            s.sendall(line.encode() + b"\n")
            answer = b""
            while not answer.endswith(b"\n"):
                chunk = s.recv(4096)
                if not chunk:
                    break
                answer += chunk
        text = answer.decode().strip()
        assert text.startswith("ok"), f"drivebus-sim refused '{line}': {text}"
        return text

    def register(self, address, name):
        return int(self.command(f"get {address} {name}").split()[1])

    def writes(self, address):
        """The drive's write log: [(register, value), ...]."""
        out = []
        for item in self.command(f"writes {address}").split()[1:]:
            reg, value = item.split("=")
            out.append((int(reg, 16), int(value)))
        return out


def wait_until(condition, timeout, what):
    """Polls `condition` until it holds; fails the test naming `what` after `timeout` seconds."""
    deadline = time.monotonic() + timeout
    while True:
        result = condition()
        if result:
            return result
        if time.monotonic() > deadline:
            pytest.fail(f"not within {timeout} s: {what}")
        time.sleep(0.02)


@pytest.fixture(scope="session")
def bus_name():
    return _env("DRIVEBUS_TEST_BUS")


@pytest.fixture(scope="session")
def sim():
    return Sim(_env("DRIVEBUS_TEST_SIM_CONTROL"))


@pytest.fixture
def bus(bus_name):
    return drivebus.Bus.connect(bus_name, application="pytest")


@pytest.fixture
def pump(bus):
    drive = bus.drive("pump")
    wait_until(lambda: drive.snapshot(2.0).health == "online", 20, "the pump online")
    yield drive
    # Whatever a test left, the next one starts with the lease free and the pump stopped.
    try:
        drive.release_control()
    except drivebus.NotPermitted:
        pass
