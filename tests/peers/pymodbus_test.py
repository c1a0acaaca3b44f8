#!/usr/bin/python3
# SPDX-License-Identifier: Apache-2.0
"""pymodbus, an independent Modbus RTU master, against drivebus-sim.

An Altivar 21 at address 1 and an Altivar 58 at address 2, 19200 8N1. Run through
sim_harness.sh, which provides SIM_LINK (the tty) and SIM_CONTROL (the control socket).
Written for pymodbus 3.0 (Debian python3-pymodbus): the client methods take the slave as
`slave=`, while request objects built by hand (FC43/14) still take `unit=`.
Exit status: 0 when every case passed, 1 when one failed or pymodbus cannot be imported (scripts/setup
installs it: a peer that is missing is a failure, never a skip).
"""

import os
import socket
import sys
import traceback

try:
    from pymodbus.client import ModbusSerialClient
    from pymodbus.framer.rtu_framer import ModbusRtuFramer
    from pymodbus.mei_message import ReadDeviceInformationRequest, ReadDeviceInformationResponse
    from pymodbus.pdu import ExceptionResponse
except ImportError as e:
    print(f"pymodbus_test: FAIL: pymodbus cannot be imported by {sys.executable} ({e}); "
          "scripts/setup installs python3-pymodbus, python3-serial and python3-serial-asyncio")
    sys.exit(1)

ATV21 = 1
ATV58 = 2
FD00, FD01, FA01 = 0xFD00, 0xFD01, 0xFA01
F875 = 0x0875          # F875..F879: the read indirect block's slot selectors
READ_BLOCK = 0x1875
W450 = 450

LINK = os.environ.get("SIM_LINK")
CONTROL = os.environ.get("SIM_CONTROL")


class CheckFailed(Exception):
    pass


def check(condition, message):
    if not condition:
        raise CheckFailed(message)


def expect_eq(what, actual, expected):
    check(actual == expected, f"{what}: got {actual!r}, expected {expected!r}")


def describe(response):
    if isinstance(response, ExceptionResponse):
        return f"exception {response.exception_code} (function 0x{response.function_code:02X})"
    return repr(response)


def ctl(command):
    """One control command; returns the answer after "ok", raises on "error: ..."."""
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as s:
        s.settimeout(5)
        s.connect(CONTROL)
        s.sendall(command.encode() + b"\n")
        answer = b""
        while not answer.endswith(b"\n"):
            chunk = s.recv(4096)
            if not chunk:
                break
            answer += chunk
    text = answer.decode().strip()
    check(text == "ok" or text.startswith("ok "), f"control command {command!r} answered {text!r}")
    return text[2:].strip()


def ctl_get(address, name):
    return int(ctl(f"get {address} {name}"))


def counters():
    fields = {}
    for word in ctl("stats").split():
        key, eq, value = word.partition("=")
        if eq and value.isdigit():
            fields.setdefault(key, int(value))  # the first "exceptions=" is the total
    return fields


class Peer:
    """The pymodbus client, counting the requests it sends (retries=0: one per call)."""

    def __init__(self):
        self.client = ModbusSerialClient(port=LINK, framer=ModbusRtuFramer, baudrate=19200, bytesize=8,
                                         parity="N", stopbits=1, timeout=1, retries=0)
        self.requests = 0
        self.exceptions = 0
        self.counters_before = {}

    def connect(self):
        check(self.client.connect(), f"pymodbus cannot open {LINK}")

    def close(self):
        self.client.close()

    def _ok(self, what, response):
        self.requests += 1
        check(response is not None and not isinstance(response, Exception), f"{what}: no reply ({response!r})")
        check(not response.isError(), f"{what}: error reply: {describe(response)}")
        return response

    def read(self, slave, address, count):
        what = f"FC03 slave {slave} 0x{address:04X} x{count}"
        r = self._ok(what, self.client.read_holding_registers(address, count, slave=slave))
        expect_eq(f"{what}: number of values", len(r.registers), count)
        return r.registers

    def write_single(self, slave, address, value):
        what = f"FC06 slave {slave} 0x{address:04X} = {value}"
        r = self._ok(what, self.client.write_register(address, value, slave=slave))
        expect_eq(f"{what}: echoed address", r.address, address)
        expect_eq(f"{what}: echoed value", r.value, value)

    def write_multiple(self, slave, address, values):
        what = f"FC16 slave {slave} 0x{address:04X} = {values}"
        r = self._ok(what, self.client.write_registers(address, values, slave=slave))
        expect_eq(f"{what}: echoed address", r.address, address)
        expect_eq(f"{what}: echoed quantity", r.count, len(values))

    def identify(self, slave, read_code, object_id=0):
        what = f"FC43/14 slave {slave} read code {read_code}"
        request = ReadDeviceInformationRequest(read_code=read_code, object_id=object_id, unit=slave)
        r = self._ok(what, self.client.execute(request))
        check(isinstance(r, ReadDeviceInformationResponse), f"{what}: unexpected reply {r!r}")
        return r

    def expect_exception(self, what, code, call):
        self.requests += 1
        self.exceptions += 1
        r = call()
        check(isinstance(r, ExceptionResponse), f"{what}: expected exception {code}, got {describe(r)}")
        expect_eq(f"{what}: exception code", r.exception_code, code)


# ---- cases ------------------------------------------------------------------------------------

def case_read_status(peer):
    """ATV21: FD00 and FD01 read alone match the simulator's values."""
    expect_eq("FD00 (output frequency)", peer.read(ATV21, FD00, 1)[0], ctl_get(ATV21, "FD00"))
    expect_eq("FD01 (status)", peer.read(ATV21, FD01, 1)[0], ctl_get(ATV21, "FD01"))


def case_fc06_fa01(peer):
    """ATV21: FC06 FA01 = 6000, read back."""
    ctl(f"set {ATV21} FA01 0")
    peer.write_single(ATV21, FA01, 6000)
    expect_eq("FA01 read back", peer.read(ATV21, FA01, 1)[0], 6000)
    expect_eq("FA01 in the simulator", ctl_get(ATV21, "FA01"), 6000)


def case_fc16_fa01(peer):
    """ATV21: FC16 (one register) FA01 = 1234, read back."""
    ctl(f"set {ATV21} FA01 0")
    peer.write_multiple(ATV21, FA01, [1234])
    expect_eq("FA01 read back", peer.read(ATV21, FA01, 1)[0], 1234)
    expect_eq("FA01 in the simulator", ctl_get(ATV21, "FA01"), 1234)


def case_indirect_block(peer):
    """ATV21: F875..F879 = 1..5 by FC06, a power cycle, then the read block 0x1875 x5."""
    for slot in range(5):
        peer.write_single(ATV21, F875 + slot, slot + 1)
        expect_eq(f"F87{5 + slot} in the simulator", ctl_get(ATV21, f"F87{5 + slot}"), slot + 1)
    # In effect after a reset (guide section 6): until then the block selects nothing.
    expect_eq("block before a reset", peer.read(ATV21, READ_BLOCK, 5), [0, 0, 0, 0, 0])
    ctl(f"power {ATV21}")
    fd00 = peer.read(ATV21, FD00, 1)[0]
    fd01 = peer.read(ATV21, FD01, 1)[0]
    block = peer.read(ATV21, READ_BLOCK, 5)
    expect_eq("block word 1 (F875=1: FD01) vs FD01 read alone", block[0], fd01)
    expect_eq("block word 2 (F876=2: FD00) vs FD00 read alone", block[1], fd00)
    expect_eq("block word 3 (F877=3: FE03)", block[2], ctl_get(ATV21, "FE03"))
    expect_eq("block word 4 (F878=4: FE05)", block[3], ctl_get(ATV21, "FE05"))
    expect_eq("block word 5 (F879=5: FC91)", block[4], ctl_get(ATV21, "FC91"))


def case_fc03_two_words_at_fd00(peer):
    """ATV21: a 2-word FC03 at FD00 -> exception 3."""
    peer.expect_exception("FC03 slave 1 0xFD00 x2", 3,
                          lambda: peer.client.read_holding_registers(FD00, 2, slave=ATV21))


def case_fc06_to_ffff(peer):
    """ATV21: FC06 to 0xFFFF -> exception 2."""
    peer.expect_exception("FC06 slave 1 0xFFFF = 0", 2,
                          lambda: peer.client.write_register(0xFFFF, 0, slave=ATV21))


def case_device_identification(peer):
    """ATV21: FC43/14 read code 1 -> objects 0, 1, 2."""
    r = peer.identify(ATV21, read_code=1)
    expect_eq("read code echoed", r.read_code, 1)
    expect_eq("number of objects", r.number_of_objects, 3)
    expect_eq("object ids", sorted(r.information), [0, 1, 2])
    vendor = r.information[0]
    check(isinstance(vendor, bytes) and len(vendor) > 0, f"object 0 (vendor name) is empty: {vendor!r}")
    check(all(0x20 <= b < 0x7F for b in vendor), f"object 0 (vendor name) is not printable ASCII: {vendor!r}")
    expect_eq("object 1 (product code)", r.information[1], b"ATV21H075M3X")
    expect_eq("object 2 (revision)", r.information[2], b"0201")
    expect_eq("more follows", r.more_follows, 0)


def case_atv58_block(peer):
    """ATV58: W450..W459 in one FC03 of 10 words."""
    values = [450 + i * 7001 for i in range(10)]  # distinct, some above 32767
    for i, v in enumerate(values):
        ctl(f"set {ATV58} W{450 + i} {v}")
    expect_eq("W450..W459", peer.read(ATV58, W450, 10), values)


def case_atv58_33_words(peer):
    """ATV58: FC03 of 33 words (32 max) -> exception 3."""
    peer.expect_exception("FC03 slave 2 450 x33", 3,
                          lambda: peer.client.read_holding_registers(W450, 33, slave=ATV58))


def case_counters(peer):
    """Simulator: the counters grew by exactly what pymodbus sent (run last)."""
    before, after = peer.counters_before, counters()
    expect_eq("requests counted", after["requests"] - before["requests"], peer.requests)
    expect_eq("replies counted", after["replies"] - before["replies"], peer.requests)
    expect_eq("exception replies counted", after["exceptions"] - before["exceptions"], peer.exceptions)
    expect_eq("broken frames counted", after["broken"] - before["broken"], 0)


CASES = [case_read_status, case_fc06_fa01, case_fc16_fa01, case_indirect_block, case_fc03_two_words_at_fd00,
         case_fc06_to_ffff, case_device_identification, case_atv58_block, case_atv58_33_words, case_counters]


def main():
    if not LINK or not CONTROL:
        print("pymodbus_test: SIM_LINK and SIM_CONTROL must be set (run it through sim_harness.sh)",
              file=sys.stderr)
        return 2
    import pymodbus
    print(f"pymodbus_test: pymodbus {pymodbus.__version__}, {LINK}")

    # No Modbus time-out on the Altivar 21 (F803 = 0): its status must not turn to a fault
    # between two reads of a case.
    ctl(f"set {ATV21} F803 0")
    peer = Peer()
    peer.counters_before = counters()
    peer.connect()
    failed = []
    try:
        for case in CASES:
            name = case.__doc__
            try:
                case(peer)
                print(f"ok   {name}")
            except CheckFailed as e:
                failed.append(name)
                print(f"FAIL [{name}]: {e}", file=sys.stderr)
            except Exception:  # a pymodbus error: report it as this case's failure
                failed.append(name)
                print(f"FAIL [{name}]: unexpected error:\n{traceback.format_exc()}", file=sys.stderr)
    finally:
        peer.close()

    total = len(CASES)
    print(f"pymodbus_test: {total - len(failed)}/{total} cases passed, {len(failed)} failed "
          f"({peer.requests} Modbus requests)")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
