#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""drivebus from Python beside pymodbus, on the same simulated line (drivebus-sim, an ATV21 at
address 1, 19200 8N1, paced at the wire's speed):

1. a polled value, as drivebus gives it: the latest snapshot's FD00 (no line time);
2. an on-demand read of FD00 through drivebusd (drivebus's Drive.read: a line round trip);
3. the same read with pymodbus owning the line (drivebusd stopped first: one master per line).

Prints a table of median, p99 and max per read, and the figures as JSON with --json.

    PYTHONPATH=build/python python3 bench/python/read_bench.py --build build [--reads 500]
"""
import argparse
import json
import os
import pathlib
import signal
import statistics
import subprocess
import sys
import tempfile
import time


def percentile(samples, p):
    ordered = sorted(samples)
    return ordered[min(len(ordered) - 1, int(round(p / 100 * (len(ordered) - 1))))]


def summary(samples_s):
    us = [s * 1e6 for s in samples_s]
    return {"n": len(us), "median_us": statistics.median(us), "p99_us": percentile(us, 99), "max_us": max(us)}


def wait_for(condition, timeout, what):
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            sys.exit(f"read_bench: not within {timeout} s: {what}")
        time.sleep(0.02)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--build", default="build", help="the build tree (drivebusd, drivebus-sim, python/)")
    parser.add_argument("--reads", type=int, default=500)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    build = pathlib.Path(args.build).resolve()
    sys.path.insert(0, str(build / "python"))
    import drivebus  # noqa: E402  (from the build tree)
    from pymodbus.client import ModbusSerialClient  # noqa: E402
    from pymodbus.framer.rtu_framer import ModbusRtuFramer  # noqa: E402

    work = pathlib.Path(tempfile.mkdtemp(prefix="drivebus-pybench-"))
    link, control = work / "tty", work / "control"
    sim = subprocess.Popen([str(build / "sim/drivebus-sim"), "--link", str(link), "--control", str(control),
                            "--drive", "1:atv21", "--baud", "19200", "--parity", "none"],
                           stdin=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    wait_for(lambda: link.exists() and control.exists(), 10, "drivebus-sim's pty")
    bus = f"pybench{os.getpid()}"
    config = work / "drivebusd.toml"
    config.write_text(f"""[realtime]
mode = "off"
lock_memory = false
[[bus]]
name = "{bus}"
device = "{link}"
baud = 19200
parity = "none"
  [[bus.drive]]
  name = "pump"
  address = 1
  profile = "atv21"
    [[bus.drive.poll]]
    registers = ["FD00"]
    period = "50ms"
""")
    daemon = subprocess.Popen([str(build / "daemon/drivebusd"), "--config", str(config)],
                              stdin=subprocess.DEVNULL, stderr=subprocess.DEVNULL, stdout=subprocess.DEVNULL)
    results = {}
    try:
        def connected():
            try:
                return drivebus.Bus.connect(bus, application="pybench")
            except drivebus.DrivebusError:
                return None
        wait_for(lambda: connected() is not None, 20, "drivebusd announcing the bus")
        pump = connected().drive("pump")
        wait_for(lambda: pump.snapshot(1.0).raw("FD00") is not None, 20, "FD00 polled")

        polled = []
        for _ in range(args.reads * 10):
            t = time.perf_counter()
            pump.snapshot(0.0).value("FD00")
            polled.append(time.perf_counter() - t)
        results["drivebus: polled value (snapshot)"] = summary(polled)

        on_demand = []
        for _ in range(args.reads):
            t = time.perf_counter()
            pump.read("FD00")
            on_demand.append(time.perf_counter() - t)
        results["drivebus: on-demand read (drivebusd)"] = summary(on_demand)
    finally:
        daemon.send_signal(signal.SIGTERM)
        daemon.wait(timeout=20)

    client = ModbusSerialClient(port=str(link), framer=ModbusRtuFramer, baudrate=19200, bytesize=8, parity="N",
                                stopbits=1, timeout=1, retries=0)
    try:
        if not client.connect():
            sys.exit("read_bench: pymodbus could not open the pty")
        direct = []
        failures = 0
        for _ in range(args.reads):
            t = time.perf_counter()
            r = client.read_holding_registers(0xFD00, 1, slave=1)
            elapsed = time.perf_counter() - t
            if r.isError():
                failures += 1
                continue
            direct.append(elapsed)
        results["pymodbus: read owning the line"] = summary(direct)
        results["pymodbus: read owning the line"]["failures"] = failures
    finally:
        client.close()
        sim.send_signal(signal.SIGTERM)
        sim.wait(timeout=10)

    if args.json:
        print(json.dumps(results, indent=2))
        return
    print(f"| read of FD00 ({args.reads} on the line, {args.reads * 10} polled) | median | p99 | max |")
    print("|---|---|---|---|")
    for name, s in results.items():
        print(f"| {name} | {s['median_us']:.1f} µs | {s['p99_us']:.1f} µs | {s['max_us']:.1f} µs |")


if __name__ == "__main__":
    main()
