#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Logs every snapshot of a bus's drives to CSV, on asyncio: one row per snapshot and register,
with drivebusd's sequence (a gap would show a missed snapshot), no thread of its own.

    python3 csv_logger.py --bus line1 --registers FD00,FD01 --seconds 60 > plant.csv
"""
import argparse
import asyncio
import csv
import sys
import threading

import drivebus
import drivebus.aio


def known(drive, register):
    try:
        drive.native.resolve(register)
        return True
    except drivebus.InvalidArgument:
        return False


async def follow(drive, registers, writer, counts):
    registers = [r for r in registers if known(drive, r)]  # the ones its profile names
    last = None
    async for snap in drive.snapshots():
        if last is not None and snap.sequence != last + 1:
            counts["gaps"] += 1
        last = snap.sequence
        counts["snapshots"] += 1
        for reg in registers:
            writer.writerow([snap.published_ns, drive.name, snap.sequence, reg, snap.raw(reg), snap.value(reg)])


async def main(args):
    registers = [r for r in args.registers.split(",") if r]
    writer = csv.writer(sys.stdout)
    writer.writerow(["published_ns", "drive", "sequence", "register", "raw", "value"])
    counts = {"snapshots": 0, "gaps": 0}
    async with await drivebus.aio.Bus.connect(args.bus, application="csv-logger") as bus:
        names = [d["name"] for d in bus.native.status(2.0)["drives"]]
        tasks = [asyncio.create_task(follow(bus.drive(n), registers, writer, counts)) for n in names]
        await asyncio.sleep(args.seconds)
        for t in tasks:
            t.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)
    print(f"csv-logger: {counts['snapshots']} snapshots, {counts['gaps']} gaps, "
          f"{threading.active_count()} Python thread(s)", file=sys.stderr)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bus", default="", help="the bus (default: the only one)")
    parser.add_argument("--registers", default="FD00", help="registers to log, by name, comma-separated")
    parser.add_argument("--seconds", type=float, default=60.0)
    asyncio.run(main(parser.parse_args()))
