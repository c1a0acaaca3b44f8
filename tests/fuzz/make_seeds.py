#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Writes the binary seed corpora of the fuzz targets (the text ones are written by hand):
run it again after a change of layout or input format: python3 tests/fuzz/make_seeds.py

fuzz_admission: shm::Request chunks as a client leaves them. The layout is include/drivebus/shm.hpp's Request (payload version 5, 376 bytes, little-endian):
version u32, size u32, correlation u64, client u64, lease_token u64[2], kind u8, flags u8,
address u8, function u8, start u16, count u16, pid i32, reserved u32, drive char[32],
client_name char[32], values u16[123], padding to 8, deadline_ns i64.

fuzz_sim_frames: records [flags][length][request without its CRC]; (flags >> 1) x 10 ms pass
before each.

fuzz_echo_filter: [setting 0 off, 1 on, 2 auto] then records [0][length][request] (a request
sent) and [1][k][length][bytes] (a read: the next k bytes of the echo, then the bytes).

fuzz_ctl_format: [mode 0 value, 1 duration, 2 join][register index][text]. Register indexes are
those of profiles/atv21.toml's registers in order (2 is FA01), then 75 the target's signed test
register; 76 and above, none.
"""
import pathlib
import struct

VERSION, SIZE = 5, 376
READ, WRITE, IDENTIFY, BROADCAST, RENEW, RELEASE, PROBE = range(7)


def request(kind, drive="", address=0, start=0, count=0, values=(), function=0, flags=0, deadline_ns=0):
    head = struct.pack("<IIQQQQBBBBHHiI", VERSION, SIZE, 7, 0x1234, 0, 0, kind, flags, address, function, start,
                       count, 1234, 0)
    body = drive.encode().ljust(32, b"\0") + b"pump-control[1234]".ljust(32, b"\0")
    words = struct.pack("<123H", *(list(values) + [0] * (123 - len(values))))
    tail = (head + body + words).ljust(SIZE - 8, b"\0")
    return tail + struct.pack("<q", deadline_ns)


ADMISSION = {
    "read_pump_fd00": request(READ, "pump", start=0xFD00, count=1),
    "read_pump_block": request(READ, "pump", start=0x1875, count=5),
    "read_fan_w450_by_address": request(READ, "", address=2, start=0x01C2, count=10),
    "write_pump_fa01": request(WRITE, "pump", start=0xFA01, count=1, values=[4000]),
    "write_pump_fa00_deadline": request(WRITE, "pump", start=0xFA00, count=1, values=[0xC400], deadline_ns=5_000_000_000),
    "write_pump_block": request(WRITE, "pump", start=0x1870, count=2, values=[0xC400, 4000], function=16),
    "write_fan_w400_w401": request(WRITE, "fan", start=0x0190, count=2, values=[15, 400]),
    "write_pump_f803_out_of_range": request(WRITE, "pump", start=0x0803, count=1, values=[1000]),
    "identify_pump": request(IDENTIFY, "pump"),
    "broadcast_fa00": request(BROADCAST, "", start=0xFA00, count=1, values=[0xC000], function=6),
    "lease_renew_pump": request(RENEW, "pump", flags=1),
    "lease_release_fan": request(RELEASE, "fan"),
    "probe_17": request(PROBE, "", address=17, start=0),
}


def record(flags, body):
    return bytes([flags, len(body)]) + body


FD00 = bytes.fromhex("0103FD000001")
SIM_FRAMES = {
    "read_fd00": record(0, FD00),
    "read_block_after_selectors": record(0, bytes.fromhex("01060875" "0001")) + record(2, bytes.fromhex("01060876" "0002"))
    + record(2, bytes.fromhex("010318750002")),
    "run_then_ramp": record(0, bytes.fromhex("0106FA01" "0FA0")) + record(0, bytes.fromhex("0106FA00" "C400"))
    + record(100, FD00) + record(200, FD00),
    "write_block": record(0, bytes.fromhex("01101870000204C4000FA0")),
    "identify": record(0, bytes.fromhex("012B0E0100")),
    "atv58_read_write": record(0, bytes.fromhex("020301C2000A")) + record(0, bytes.fromhex("02100190000204000F0190")),
    "broadcast_then_read": record(0, bytes.fromhex("0006FA00C000")) + record(4, FD00),
    "modbus_timeout": record(0, bytes.fromhex("01060803" "0001")) + record(254, FD00) + record(254, FD00),
    "illegal_function": record(0, bytes.fromhex("0107")) + record(0, bytes.fromhex("01030803000A")),
    # Function 0 has no exception reply: the simulator once used the reply it could not build.
    "function_zero": record(0, bytes.fromhex("010006")) + record(0, FD00),
}


def echo_record(request):
    return bytes([0, len(request)]) + request


def read_record(k, data=b""):
    return bytes([1, k, len(data)]) + data


REQ = bytes.fromhex("0103FD000001B5A6")
REPLY = bytes.fromhex("0103020000B844")
ECHO_FILTER = {
    "on_echo_then_reply": bytes([1]) + echo_record(REQ) + read_record(8, REPLY),
    "on_split_echo": bytes([1]) + echo_record(REQ) + read_record(3) + read_record(5, REPLY),
    "on_collision": bytes([1]) + echo_record(REQ) + read_record(2, b"\xff"),
    "auto_no_echo": bytes([2]) + echo_record(REQ) + read_record(0, REPLY),
    "auto_echo": bytes([2]) + echo_record(REQ) + read_record(4) + read_record(4, REPLY),
    "auto_fc06_undecided": bytes([2]) + echo_record(bytes.fromhex("0106FA00C4009C7A")) + read_record(8),
    "off": bytes([0]) + echo_record(REQ) + read_record(0, REPLY),
}

CTL_FORMAT = {
    "value_fa01_hz": bytes([0, 2]) + b"40Hz",
    "value_fa01_spaced": bytes([0, 2]) + b" 30.5 Hz ",
    "value_hex": bytes([0, 0]) + b"0xC400",
    "value_signed_raw": bytes([0, 75]) + b"-5",
    "value_signed_unit": bytes([0, 75]) + b"-0.5 %",
    "value_unknown_register": bytes([0, 90]) + b"300",
    "duration_ms": bytes([1, 0]) + b"500ms",
    "duration_min": bytes([1, 0]) + b"1.5min",
    "duration_us": bytes([1, 0]) + b"250us",
    "join_units": bytes([2, 0]) + b"FA01\n30.5\nHz\nFA00\n0xC400",
}

here = pathlib.Path(__file__).resolve().parent / "corpus"
for target, seeds in {"fuzz_admission": ADMISSION, "fuzz_sim_frames": SIM_FRAMES, "fuzz_echo_filter": ECHO_FILTER,
                      "fuzz_ctl_format": CTL_FORMAT}.items():
    out = here / target
    out.mkdir(parents=True, exist_ok=True)
    for name, data in seeds.items():
        assert target != "fuzz_admission" or len(data) == SIZE, name
        (out / name).write_bytes(data)
