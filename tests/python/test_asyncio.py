# SPDX-License-Identifier: Apache-2.0
"""drivebus.aio on asyncio's loop: requests as coroutines, snapshots by `async for`, no thread of
the module's own, and a loop that hangs losing its lease."""
import asyncio
import csv
import io
import os
import pathlib
import subprocess
import sys
import threading
import time

import pytest

import drivebus
import drivebus.aio
from conftest import RUN_FORWARD, STOP, wait_until


def threads_of_this_process():
    return len(os.listdir("/proc/self/task"))


def thread_names():
    return sorted(open(f"/proc/self/task/{t}/comm").read().strip() for t in os.listdir("/proc/self/task"))


def run(coroutine):
    return asyncio.run(asyncio.wait_for(coroutine, 30))


def test_reads_writes_and_snapshots_on_the_loop_start_no_thread(bus_name, sim):
    # The process's first connection starts iceoryx's runtime, whose one thread ("KeepAlive")
    # tells RouDi this process lives; beside it, nothing.
    drivebus.Bus.connect(bus_name)
    assert thread_names() == sorted(["KeepAlive", "python3"]), thread_names()
    python_threads = set(threading.enumerate())
    os_threads = threads_of_this_process()

    async def main():
        async with await drivebus.aio.Bus.connect(bus_name, application="pytest-aio") as bus:
            pump = bus.drive("pump")
            sim.command("set 1 FA01 1234")
            assert await pump.read("FA01") == [1234]
            assert await pump.read_value("FA01") == pytest.approx(12.34)
            await pump.write_value("FA01", 41.5)
            assert sim.register(1, "FA01") == 4150
            sequences = []
            async for snap in pump.snapshots():
                sequences.append(snap.sequence)
                if len(sequences) == 5:
                    break
            # Each one newer than the last, none skipped at this pace.
            assert sequences == list(range(sequences[0], sequences[0] + 5))
            atv = drivebus.aio.Altivar(pump)
            await atv.run_forward()
            assert sim.register(1, "FA00") == RUN_FORWARD
            await atv.stop()
            await pump.release_control()
            assert bus.status()["drivebusd"] == "running"
            return threads_of_this_process()

    during = run(main())
    assert set(threading.enumerate()) == python_threads
    assert during == os_threads, f"the module started a thread: {thread_names()}"


def test_errors_of_coroutines_come_by_kind(bus_name):
    async def main():
        async with await drivebus.aio.Bus.connect(bus_name) as bus:
            pump = bus.drive("pump")
            with pytest.raises(drivebus.InvalidArgument):
                await pump.read("ZZ99")
            with pytest.raises(drivebus.InvalidArgument):
                await drivebus.aio.Altivar(pump).set_frequency(900.0)
            with pytest.raises(drivebus.NotPermitted):
                await pump.keep_alive()  # no lease held

    run(main())


def test_concurrent_requests_each_get_their_own_answer(bus_name, sim):
    async def main():
        async with await drivebus.aio.Bus.connect(bus_name) as bus:
            pump, fan = bus.drive("pump"), bus.drive("fan")
            sim.command("set 1 F803 9")
            results = await asyncio.gather(*[pump.read("F803") for _ in range(4)],
                                           *[fan.read("W450", 3) for _ in range(4)])
            assert results[:4] == [[9]] * 4
            assert all(len(r) == 3 for r in results[4:])

    run(main())


def test_a_hung_loop_loses_its_lease_and_the_drive_falls_back(bus_name, sim):
    async def main():
        async with await drivebus.aio.Bus.connect(bus_name, application="hung") as bus:
            pump = bus.drive("pump")
            atv = drivebus.aio.Altivar(pump)
            await atv.set_frequency(25.0)
            await atv.run_forward()
            assert sim.register(1, "FA00") == RUN_FORWARD
            await pump.keep_alive()
            # The loop hangs (a blocking call in a coroutine): nothing renews the lease (1 s).
            deadline = time.monotonic() + 10
            while sim.register(1, "FA00") != STOP and time.monotonic() < deadline:
                time.sleep(0.05)
            assert sim.register(1, "FA00") == STOP, "no fallback while the loop hung"
            # Back, the loop finds the lease gone: its renewal is refused.
            with pytest.raises(drivebus.NotPermitted):
                await pump.keep_alive()

    run(main())


def test_a_cancelled_request_drops_only_its_answer(bus_name):
    async def main():
        async with await drivebus.aio.Bus.connect(bus_name) as bus:
            pump = bus.drive("pump")
            task = asyncio.ensure_future(pump.read("FD00"))
            await asyncio.sleep(0)
            task.cancel()
            with pytest.raises(asyncio.CancelledError):
                await task
            # Its answer arrives later and is dropped; the next request is answered as usual.
            assert len(await pump.read("FD01")) == 1

    run(main())


def test_the_example_csv_logger_misses_no_snapshot(bus_name):
    example = pathlib.Path(__file__).resolve().parents[2] / "examples" / "python" / "csv_logger.py"
    done = subprocess.run([sys.executable, str(example), "--bus", bus_name, "--registers", "FD00,FD01,W450",
                           "--seconds", "3"], stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    rows = list(csv.DictReader(io.StringIO(done.stdout)))
    by_drive = {}
    for row in rows:
        by_drive.setdefault(row["drive"], set()).add(int(row["sequence"]))
    # Both drives, every snapshot of each in between the first and the last (polls of 50 and 100 ms).
    assert set(by_drive) == {"pump", "fan"}, done.stderr
    for drive, sequences in by_drive.items():
        assert len(sequences) >= 10, (drive, len(sequences))
        assert sequences == set(range(min(sequences), max(sequences) + 1)), f"{drive}: a snapshot missed"
    assert {r["register"] for r in rows if r["drive"] == "fan"} == {"W450"}
    assert ", 0 gaps, 1 Python thread(s)" in done.stderr, done.stderr
