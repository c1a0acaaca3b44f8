#!/usr/bin/python3
# SPDX-License-Identifier: Apache-2.0
"""pymodbus's TCP client, an independent Modbus TCP master, through drivebus-gateway.

    pymodbus_tcp.py PORT check          reads, writes, identification, diagnostics and
                                        exceptions: one JSON object on stdout
    pymodbus_tcp.py PORT hold REF       takes the pump's control: FA00 = 0xC400 (run) and FA01 =
                                        REF every 200 ms; "holding" once both are acknowledged;
                                        until killed
    pymodbus_tcp.py PORT write REG V    one FC06 write: "ok" or "exception N"

Written for pymodbus 3.0 (Debian python3-pymodbus): client methods take `slave=`, request
objects built by hand take `unit=`. Exit status 0, or 1 with the reason on stderr (pymodbus
missing is a failure: scripts/setup installs it).
"""

import json
import sys
import time

try:
    from pymodbus.client import ModbusTcpClient
    from pymodbus.diag_message import ReturnQueryDataRequest
    from pymodbus.mei_message import ReadDeviceInformationRequest
except ImportError as e:
    print(f"pymodbus_tcp: pymodbus cannot be imported by {sys.executable} ({e})", file=sys.stderr)
    sys.exit(1)

PUMP, FAN = 1, 2
FA00, FA01, FD06, W450 = 0xFA00, 0xFA01, 0xFD06, 450


def outcome(r):
    if r.isError():
        return {"exception": getattr(r, "exception_code", None), "text": str(r)}
    return None


def check(client):
    out = {}
    r = client.read_holding_registers(FD06, 1, slave=PUMP)
    out["fd06"] = outcome(r) or r.registers[0]
    r = client.read_input_registers(FD06, 1, slave=PUMP)
    out["fd06_input"] = outcome(r) or r.registers[0]
    r = client.read_holding_registers(W450, 3, slave=FAN)
    out["w450"] = outcome(r) or list(r.registers)
    r = client.write_register(FA01, 1500, slave=PUMP)
    out["write_fa01"] = outcome(r) or "ok"
    r = client.write_registers(FA01, [1600], slave=PUMP)
    out["write_fa01_fc16"] = outcome(r) or "ok"
    r = client.execute(ReadDeviceInformationRequest(read_code=1, object_id=0, unit=PUMP))
    out["ident"] = outcome(r) or {str(k): v.decode("ascii", "replace") for k, v in r.information.items()}
    r = client.execute(ReadDeviceInformationRequest(read_code=1, object_id=0, unit=FAN))
    out["fan_ident"] = outcome(r) or "answered"
    r = client.execute(ReturnQueryDataRequest(message=0xA537, unit=PUMP))
    out["echo"] = outcome(r) or r.message
    r = client.read_holding_registers(FD06, 1, slave=99)
    out["unit99"] = outcome(r) or "answered"
    r = client.read_holding_registers(FD06, 2, slave=PUMP)  # the ATV21 reads one word at a time
    out["two_words"] = outcome(r) or "answered"
    r = client.write_register(0xFD06, 1, slave=PUMP)  # a read-only register
    out["write_fd06"] = outcome(r) or "ok"
    print(json.dumps(out), flush=True)


def hold(client, reference):
    said = False
    while True:
        a = client.write_register(FA00, 0xC400, slave=PUMP)
        b = client.write_register(FA01, reference, slave=PUMP)
        if not said and not a.isError() and not b.isError():
            print("holding", flush=True)
            said = True
        elif a.isError() or b.isError():
            print(f"refused {a} {b}", flush=True)
        time.sleep(0.2)


def main():
    if len(sys.argv) < 3:
        print(__doc__, file=sys.stderr)
        return 2
    client = ModbusTcpClient("127.0.0.1", port=int(sys.argv[1]), timeout=5, retries=0)
    if not client.connect():
        print(f"pymodbus_tcp: cannot connect to port {sys.argv[1]}", file=sys.stderr)
        return 1
    mode = sys.argv[2]
    if mode == "check":
        check(client)
    elif mode == "hold":
        hold(client, int(sys.argv[3]))
    elif mode == "write":
        r = client.write_register(int(sys.argv[3], 0), int(sys.argv[4], 0), slave=PUMP)
        print(f"exception {r.exception_code}" if r.isError() else "ok", flush=True)
    else:
        print(f"pymodbus_tcp: unknown mode {mode}", file=sys.stderr)
        return 2
    client.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
