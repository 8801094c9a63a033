"""The stand-in's signals: a lidar's scan as CoppeliaSim's stock 2D laser scanners publish it.

Where it sits: ``server.Server`` answers the calls listed in ``SIGNAL_CALLS`` beside the
session's and the objects' (``sim_session``, ``sim_objects``), reading what the last step of the
``simulation`` sensed. CoppeliaSim's laser scanner models (the Hokuyo URG-04LX and SICK S300,
their "fast" variants) hand a scan to other scripts and remote clients as a string signal,
``measuredDataAtThisTime``, holding ``sim.packFloatTable`` of x, y, z in the sensor's frame for
each beam that detects something; a client reads it with ``sim.getStringSignal`` and
``sim.unpackFloatTable``. The stand-in publishes that for every robot with a lidar
(``labsim.backends.coppeliasim.lidar_signals``: the first robot's under the stock name) and,
beside it, every beam's range in doubles, which the coppeliasim backend reads: float32 points
would not give a behaviour the embedded backend's ranges. Signals a client sets (string,
int32 and float, each kind its own names, as in CoppeliaSim 4.6 to 4.10) are kept as CoppeliaSim
keeps them, until they are cleared, within bounds (``MAX_SIGNALS`` of them, ``MAX_SIGNALS_BYTES``
in all); the lidars' are read only (set one: an error). What a client unpacks is bounded too
(``MAX_UNPACKED`` values).
"""
from __future__ import annotations

import functools
import math
import struct
from collections.abc import Callable
from typing import Any

from labsim.backends.coppeliasim import lidar_signals
from labsim.runtime.serve.sim_args import E_ARGS, E_FEW, Args, Handler, SimError, as_handle, shown
from labsim.runtime.serve.simulation import Client, Simulation

SIGNAL_CALLS = tuple(f"sim.{n}" for n in (
    "getStringSignal", "setStringSignal", "clearStringSignal",
    "getInt32Signal", "setInt32Signal", "clearInt32Signal", "getFloatSignal", "setFloatSignal", "clearFloatSignal",
    "packFloatTable", "unpackFloatTable", "packDoubleTable", "unpackDoubleTable",
))
MAX_SIGNAL_BYTES = 16 << 20  # a client's own signal, and a table to pack: bounded, as every request
MAX_SIGNALS = 10_000  # signals clients set, of all kinds together
MAX_SIGNALS_BYTES = 64 << 20  # their names and values, together
MAX_UNPACKED = 1 << 20  # values one unpack returns (8 MiB of doubles; a million floats in a reply)
INT32 = (-(1 << 31), (1 << 31) - 1)


class SignalCalls:
    """The handlers of ``SIGNAL_CALLS`` (``handlers()``); ``simulation`` gives the current one."""

    def __init__(self, simulation: Callable[[], Simulation]) -> None:
        self._simulation = simulation
        self._own: dict[tuple[str, str], bytes | int | float] = {}  # (kind, name) -> value: signals clients set
        self._bytes = 0  # their names' and values' bytes

    def handlers(self) -> dict[str, Handler]:
        return {name: getattr(self, "_" + name.removeprefix("sim.")) for name in SIGNAL_CALLS}

    def _lidars(self) -> dict[str, Callable[[], bytes | None]]:
        """Each lidar signal's name and how to read it now (None before the first step)."""
        sim = self._simulation()
        out: dict[str, Callable[[], bytes | None]] = {}
        packers = (_pack_points, _pack_ranges)
        counts: dict[str, int] = {}
        for k, robot in enumerate(sim.robots):
            i = counts.get(robot.model.name, 0)
            counts[robot.model.name] = i + 1
            if robot.model.lidars:
                for name, pack in zip(lidar_signals(i), packers):
                    out[name] = functools.partial(pack, sim, k)
        return out

    def _keep(self, kind: str, name: str, value: bytes | int | float) -> None:
        """Keep a client's signal, within the bounds on their count and bytes."""
        key = (kind, name)
        size = len(name.encode()) + (len(value) if isinstance(value, bytes) else 8)
        old = self._own.get(key)
        was = 0 if old is None else len(name.encode()) + (len(old) if isinstance(old, bytes) else 8)
        if old is None and len(self._own) >= MAX_SIGNALS:
            raise SimError(f"labsim serve: {MAX_SIGNALS} signals are set, the most it keeps; clear some "
                           f"(sim.clear{kind}Signal) before setting '{shown(name)}'")
        if self._bytes - was + size > MAX_SIGNALS_BYTES:
            raise SimError(f"labsim serve: the signals set would hold more than {MAX_SIGNALS_BYTES >> 20} MiB; "
                           f"clear some (sim.clear{kind}Signal) before setting '{shown(name)}'")
        self._own[key] = value
        self._bytes += size - was

    def _clear(self, kind: str, args: Args) -> list[object]:
        name = _name(args)
        old = self._own.pop((kind, name), None)
        if old is not None:
            self._bytes -= len(name.encode()) + (len(old) if isinstance(old, bytes) else 8)
        return []

    def _getStringSignal(self, client: Client, args: Args) -> list[object]:
        name = _name(args)
        lidar = self._lidars().get(name)
        return [lidar() if lidar is not None else self._own.get(("String", name))]

    def _setStringSignal(self, client: Client, args: Args) -> list[object]:
        name = _name(args)
        if len(args) < 2:
            raise SimError(E_FEW)
        data = args[1].encode() if isinstance(args[1], str) else args[1]
        if not isinstance(data, (bytes, bytearray)):
            raise SimError(E_ARGS)
        if len(data) > MAX_SIGNAL_BYTES:
            raise SimError(f"labsim serve: a signal holds at most {MAX_SIGNAL_BYTES >> 20} MiB; "
                           f"'{shown(name)}' was given {len(data)} bytes")
        if name in self._lidars():
            raise SimError(f"labsim serve: signal '{name[:60]}' is a lidar's, published by the stand-in")
        self._keep("String", name, bytes(data))
        return []

    def _clearStringSignal(self, client: Client, args: Args) -> list[object]:
        # a lidar's signal is the stand-in's to publish: cleared no more than set
        name = _name(args)
        if name in self._lidars():
            raise SimError(f"labsim serve: signal '{name[:60]}' is a lidar's, published by the stand-in")
        return self._clear("String", args)

    def _getInt32Signal(self, client: Client, args: Args) -> list[object]:
        # int value = sim.getInt32Signal(string signalName): CoppeliaSim 4.6 to 4.10; nil when not set
        return [self._own.get(("Int32", _name(args)))]

    def _setInt32Signal(self, client: Client, args: Args) -> list[object]:
        name = _name(args)
        if len(args) < 2:
            raise SimError(E_FEW)
        value = as_handle(args[1])  # any number, cast to an integer as CoppeliaSim casts it
        if not INT32[0] <= value <= INT32[1]:
            raise SimError(f"labsim serve: an int32 signal holds -2147483648 to 2147483647, not {value}")
        self._keep("Int32", name, value)
        return []

    def _clearInt32Signal(self, client: Client, args: Args) -> list[object]:
        return self._clear("Int32", args)

    def _getFloatSignal(self, client: Client, args: Args) -> list[object]:
        # float value = sim.getFloatSignal(string signalName): CoppeliaSim 4.6 to 4.10; nil when not set
        return [self._own.get(("Float", _name(args)))]

    def _setFloatSignal(self, client: Client, args: Args) -> list[object]:
        name = _name(args)
        if len(args) < 2:
            raise SimError(E_FEW)
        value = args[1]
        if not isinstance(value, (int, float)) or isinstance(value, bool):
            raise SimError(E_ARGS)
        self._keep("Float", name, float(value))
        return []

    def _clearFloatSignal(self, client: Client, args: Args) -> list[object]:
        return self._clear("Float", args)

    def _packFloatTable(self, client: Client, args: Args) -> list[object]:
        return [_pack("f", args)]

    def _packDoubleTable(self, client: Client, args: Args) -> list[object]:
        return [_pack("d", args)]

    def _unpackFloatTable(self, client: Client, args: Args) -> list[object]:
        return [_unpack("f", args)]

    def _unpackDoubleTable(self, client: Client, args: Args) -> list[object]:
        return [_unpack("d", args)]


def _name(args: Args) -> str:
    if not args:
        raise SimError(E_FEW)
    if not isinstance(args[0], str):
        raise SimError(E_ARGS)
    return args[0]


def _readings(sim: Simulation, k: int) -> list[tuple[float, float]] | None:
    """(beam direction in rad, range in m) of robot k's lidar, as the last step sensed it."""
    if sim.steps == 0 or not sim.running:
        return None
    robot = sim.robots[k]
    lidar = robot.model.lidars[0]
    row = sim.snapshot()[k]
    return [(a, float(row[robot.row[f"lidar{b + 1}"]]))  # type: ignore[arg-type]
            for b, a in enumerate(lidar.angles_rad())]


def _pack_points(sim: Simulation, k: int) -> bytes | None:
    readings = _readings(sim, k)
    if readings is None:
        return None
    xyz = [v for a, d in readings if math.isfinite(d) for v in (d * math.cos(a), d * math.sin(a), 0.0)]
    return struct.pack(f"<{len(xyz)}f", *xyz)


def _pack_ranges(sim: Simulation, k: int) -> bytes | None:
    readings = _readings(sim, k)
    return None if readings is None else struct.pack(f"<{len(readings)}d", *(d for _, d in readings))


def _pack(kind: str, args: Args) -> bytes:
    """sim.packFloatTable / packDoubleTable(table, startIndex = 0, count = 0): little-endian."""
    if not args or not isinstance(args[0], (list, tuple)):
        raise SimError(E_FEW if not args else E_ARGS)
    table: list[Any] = list(args[0])
    start = args[1] if len(args) > 1 and isinstance(args[1], int) else 0
    count = args[2] if len(args) > 2 and isinstance(args[2], int) and args[2] > 0 else len(table) - start
    values = table[max(start, 0):max(start, 0) + count]
    if len(values) * 8 > MAX_SIGNAL_BYTES or not all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                                     for v in values):
        raise SimError(E_ARGS)
    try:
        return struct.pack(f"<{len(values)}{kind}", *values)
    except (OverflowError, struct.error):  # a float32 that cannot hold the number
        raise SimError(E_ARGS) from None


def _unpack(kind: str, args: Args) -> list[float]:
    """sim.unpackFloatTable / unpackDoubleTable(data, startIndex = 0, count = 0, byteOffset = 0)."""
    if not args:
        raise SimError(E_FEW)
    data = args[0].encode() if isinstance(args[0], str) else args[0]
    if not isinstance(data, (bytes, bytearray)):
        raise SimError(E_ARGS)
    size = struct.calcsize(kind)
    offset = min(args[3], len(data)) if len(args) > 3 and isinstance(args[3], int) and args[3] > 0 else 0
    n = (len(data) - offset) // size
    start = min(args[1], n) if len(args) > 1 and isinstance(args[1], int) and args[1] > 0 else 0
    count = min(args[2], n - start) if len(args) > 2 and isinstance(args[2], int) and args[2] > 0 else n - start
    if count > MAX_UNPACKED:
        raise SimError(f"labsim serve: an unpack returns at most {MAX_UNPACKED} values; this one would return "
                       f"{count} (pass startIndex and count to take the table in parts)")
    first = offset + start * size  # only the values asked for are decoded
    return list(struct.unpack(f"<{count}{kind}", data[first:first + count * size]))
