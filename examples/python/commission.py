#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Commissioning an Altivar through drivebusd, step by step: who it is, its state, a short run at
a low frequency, and a stop, while every other client on the board keeps the line.

    python3 commission.py --bus line1 --drive pump --hz 10 --seconds 5
"""
import argparse
import sys
import time

import drivebus


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bus", default="", help="the bus (default: the only one)")
    parser.add_argument("--drive", required=True, help="the drive's name or address")
    parser.add_argument("--hz", type=float, default=10.0, help="the test run's frequency")
    parser.add_argument("--seconds", type=float, default=5.0, help="how long it runs")
    args = parser.parse_args()

    try:
        bus = drivebus.Bus.connect(args.bus, application="commission")
    except drivebus.NotRunning as e:
        sys.exit(f"commission: {e}")
    drive = bus.drive(args.drive)
    atv = drivebus.Altivar(drive)
    try:
        identity = drive.identify()
        print(f"{drive.name} at {drive.address}: {identity['vendor']} {identity['product_code']} "
              f"{identity['revision']} (profile {drive.profile})")
    except drivebus.ModbusException:
        print(f"{drive.name} at {drive.address}: no identification (profile {drive.profile})")
    state = atv.state()
    print(f"state: running={state['running']} fault={state['fault_name'] or 'none'} "
          f"lease={state['lease']['state']}")
    if state["fault"]:
        print("resetting the fault")
        atv.reset_fault()

    atv.set_frequency(args.hz)  # takes the control lease
    atv.run_forward()
    print(f"running at {args.hz} Hz for {args.seconds} s")
    end = time.monotonic() + args.seconds
    try:
        while time.monotonic() < end:
            drive.keep_alive()  # from this loop itself: if it hangs, the drive falls back
            snap = drive.snapshot(0.5)
            print(f"  output {snap.value('FD00') or 0:.2f} Hz, status 0x{snap.raw('FD01') or 0:04X}")
            time.sleep(0.25)
    finally:
        atv.stop()
        drive.release_control()
    print("stopped, lease released")


if __name__ == "__main__":
    main()
