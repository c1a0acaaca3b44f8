# SPDX-License-Identifier: Apache-2.0
"""drivebus on asyncio: the bus's descriptor is watched by the running loop (add_reader), and
every request completes on the loop's thread. The module starts no thread.

    import asyncio, drivebus.aio

    async def main():
        async with await drivebus.aio.Bus.connect("line1") as bus:
            pump = bus.drive("pump")
            print(await pump.read_value("FD00"))
            async for snap in pump.snapshots():
                print(snap.sequence, snap.value("FD00"))

    asyncio.run(main())

A request whose awaiting task is cancelled still completes in drivebusd (a write may still be
applied); only its answer is dropped.
"""
from __future__ import annotations

import asyncio
from collections import deque
from typing import AsyncIterator, Optional, Sequence, Union

from . import _drivebus

Register = Union[str, int]


class Bus:
    """A bus of drivebusd on the running asyncio loop."""

    def __init__(self, bus: _drivebus.Bus, loop: asyncio.AbstractEventLoop) -> None:
        self._bus = bus
        self._loop = loop
        self._fd = bus.descriptor()
        loop.add_reader(self._fd, bus.dispatch)

    @classmethod
    async def connect(cls, name: str = "", application: str = "python",
                      request_timeout: float = 2.0) -> "Bus":
        """Connects to the bus `name` (empty: the only one). NotRunning, NoSuchBus as drivebus.Bus."""
        return cls(_drivebus.Bus.connect(name, application, request_timeout), asyncio.get_running_loop())

    @property
    def name(self) -> str:
        return self._bus.name

    @property
    def native(self) -> _drivebus.Bus:
        """The blocking drivebus.Bus underneath (its blocking calls would hold up the loop)."""
        return self._bus

    def status(self) -> dict:
        """The latest bus status (DaemonGone before the first)."""
        return self._bus.status(0.0)

    def daemon_alive(self) -> bool:
        return self._bus.daemon_alive()

    def drive(self, name: str) -> "Drive":
        return Drive(self, self._bus.drive(name))

    def close(self) -> None:
        """Stops watching the descriptor. The bus's requests still pending never complete."""
        if self._fd >= 0:
            self._loop.remove_reader(self._fd)
            self._fd = -1

    async def __aenter__(self) -> "Bus":
        return self

    async def __aexit__(self, *exc) -> None:
        self.close()


def _settle(future: asyncio.Future, value=None, error: Optional[BaseException] = None) -> None:
    if future.done():  # its task was cancelled: the answer is dropped
        return
    if error is not None:
        future.set_exception(error)
    else:
        future.set_result(value)


class Drive:
    """A drive, its requests as coroutines."""

    def __init__(self, bus: Bus, drive: _drivebus.Drive) -> None:
        self._bus = bus
        self._drive = drive

    @property
    def name(self) -> str:
        return self._drive.name

    @property
    def native(self) -> _drivebus.Drive:
        return self._drive

    def _future(self) -> asyncio.Future:
        return self._bus._loop.create_future()

    async def read(self, register: Register, count: int = 1) -> list:
        """Raw words from the drive (FC03), on the line now."""
        f = self._future()
        self._drive.read_async(register, count, lambda words, error: _settle(f, words, error))
        return await f

    async def read_value(self, register: Register) -> float:
        """One register from the drive, as its engineering value."""
        words = await self.read(register, 1)
        info = self._drive.info(register)
        if info is None:
            return float(words[0])
        raw = words[0]
        if info["signed"] and raw >= 0x8000:
            raw -= 0x10000
        return raw * info["scale"]

    async def write(self, register: Register, values: Union[int, Sequence[int]], *, take_over: bool = False,
                    deadline: Optional[float] = None) -> None:
        """Raw words (FC06 for one, FC16 for more); see drivebus.Drive.write."""
        f = self._future()
        self._drive.write_async(register, values, lambda error: _settle(f, None, error), take_over=take_over,
                                deadline=deadline)
        await f

    async def write_value(self, register: Register, value: float, *, take_over: bool = False,
                          deadline: Optional[float] = None) -> None:
        """An engineering value (the profile's scale and range)."""
        await self.write(register, self._drive.word_for(register, value), take_over=take_over, deadline=deadline)

    async def keep_alive(self) -> None:
        """Renews the control lease: call it from the loop's own work, a few times per lease time."""
        f = self._future()
        self._drive.keep_alive_async(lambda error: _settle(f, None, error))
        await f

    async def release_control(self) -> None:
        f = self._future()
        self._drive.release_control_async(lambda error: _settle(f, None, error))
        await f

    def snapshot(self) -> Optional[_drivebus.Snapshot]:
        """The latest snapshot, None before the first; never waits."""
        try:
            return self._drive.snapshot(0.0)
        except _drivebus.DrivebusError:
            return None

    async def snapshots(self, queue: int = 1024) -> AsyncIterator[_drivebus.Snapshot]:
        """Each new snapshot, in order. A consumer more than `queue` snapshots behind loses the
        oldest ones (its next snapshot's sequence shows the gap)."""
        pending: deque = deque(maxlen=queue)
        ready = asyncio.Event()

        def arrived(snapshot: _drivebus.Snapshot) -> None:
            pending.append(snapshot)
            ready.set()

        subscription = self._drive.on_snapshot(arrived)
        try:
            while True:
                while not pending:
                    ready.clear()
                    await ready.wait()
                yield pending.popleft()
        finally:
            subscription.cancel()


class Altivar:
    """An Altivar's typed commands as coroutines (drivebus.Altivar's, completed on the loop)."""

    def __init__(self, drive: Drive) -> None:
        self._drive = drive
        self._altivar = _drivebus.Altivar(drive.native)

    @property
    def drive(self) -> Drive:
        return self._drive

    async def _done(self, start) -> None:
        f = self._drive._future()
        start(lambda error: _settle(f, None, error))
        await f

    async def set_frequency(self, hz: float, *, take_over: bool = False, deadline: Optional[float] = None) -> None:
        await self._done(lambda cb: self._altivar.set_frequency_async(hz, cb, take_over=take_over, deadline=deadline))

    async def run_forward(self, *, take_over: bool = False, deadline: Optional[float] = None) -> None:
        await self._done(lambda cb: self._altivar.run_forward_async(cb, take_over=take_over, deadline=deadline))

    async def run_reverse(self, *, take_over: bool = False, deadline: Optional[float] = None) -> None:
        await self._done(lambda cb: self._altivar.run_reverse_async(cb, take_over=take_over, deadline=deadline))

    async def stop(self, *, take_over: bool = False, deadline: Optional[float] = None) -> None:
        await self._done(lambda cb: self._altivar.stop_async(cb, take_over=take_over, deadline=deadline))

    async def freewheel(self, *, take_over: bool = False, deadline: Optional[float] = None) -> None:
        await self._done(lambda cb: self._altivar.freewheel_async(cb, take_over=take_over, deadline=deadline))

    async def reset_fault(self, *, take_over: bool = False, deadline: Optional[float] = None) -> None:
        await self._done(lambda cb: self._altivar.reset_fault_async(cb, take_over=take_over, deadline=deadline))

    def state(self) -> Optional[dict]:
        """The latest snapshot decoded (running, fault, output_hz, ...); None before the first."""
        snap = self._drive.snapshot()
        return snap.state() if snap is not None else None
