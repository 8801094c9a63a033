"""One backend driven through a scene as the runtime drives it, each value checked on the way.

Where it sits: the half of ``labsim.backends.check`` that calls a backend. ``check_backend``
there builds the ``Scene``, drives three backends through it with ``Drive`` and compares what
they read; here each tick's calls are made, their values checked against the protocol's types
and units, and every problem written as a sentence for the backend's author.
"""
from __future__ import annotations

import contextlib
import dataclasses
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from functools import partial
from typing import Any

from labsim.backends.protocol import Backend, BackendError, BackendStateError, ContactStats, RobotRequest
from labsim.backends.scene.models import Camera, Kind, Sonar
from labsim.backends.scene.world import World

TOLERANCE = 1e-9  # pose() against the x, y, heading read in the same tick; contact time against dt_s

_TYPES = {
    Kind.DISTANCE: "a distance in metres: a float >= 0, math.inf when nothing is in range",
    Kind.NUMBER: "a finite number: a float (an int for a count such as laps), not a bool",
    Kind.BOOL: "a bool (True or False, not a number)",
    Kind.CONTACT: "a bool (True while the bumper is pressed)",
    Kind.REFLECTANCE: "a float from 0 (black) to 1 (white)",
    Kind.JOINT: "a tuple (position, velocity) of two finite floats",
    Kind.FORCE: "a tuple (tension_N,) of one finite float >= 0 (its cable pulls, never pushes)",
    Kind.BODY: "a tuple (x_m, z_m, angle_rad) of three finite floats",
}
_TUPLE_SIZES = {Kind.JOINT: 2, Kind.FORCE: 1, Kind.BODY: 3}


@dataclass(frozen=True)
class Scene:
    """What to drive: a world, what each robot asks of it, and the channels' kinds and sensors."""

    world: World
    requests: tuple[RobotRequest, ...]
    kinds: tuple[Mapping[str, Kind], ...]  # per robot: its channels' kinds
    specs: tuple[Mapping[str, Sonar | Camera], ...]  # per robot: its sonars and cameras by channel
    dt_s: float
    seed: int
    ticks: int

    def reversed(self) -> Scene:
        """The same scene with every robot asking for its channels in reverse order."""
        return dataclasses.replace(self, requests=tuple(
            dataclasses.replace(r, channels=r.channels[::-1]) for r in self.requests))


# --- one backend through the scene --------------------------------------------------------------

@dataclass(frozen=True)
class _Image:  # an image as read, kept as bytes: a backend may reuse its array for the next tick
    shape: tuple[int, ...]
    dtype: str
    data: bytes


@dataclass(frozen=True)
class Tick:
    """What one tick read: sense()'s rows (images as bytes), then each robot's pose() and contacts()."""

    readings: tuple[tuple[object, ...], ...]
    poses: tuple[object, ...]
    contacts: tuple[object, ...]


class _Abort(Exception):
    """A run that cannot go on; the message says why, for the findings."""


def _call(where: str, call: Callable[..., Any], *args: object) -> Any:
    try:
        return call(*args)
    except Exception as e:  # whatever a backend raises, it becomes one sentence of the report
        raise _Abort(f"{where} raised {type(e).__name__}: {e}") from e


class Drive:
    """One backend driven through the scene as the runtime drives it: each tick ``sense``,
    ``pose`` and ``contacts``, then ``act`` or ``command``, then ``step``. A ``checked`` run
    also checks every value on the way, the refusals after the drive and the calls after
    ``close``; every problem goes to ``findings``."""

    def __init__(self, backend: Backend, scene: Scene, findings: dict[str, str], checked: bool = False) -> None:
        self.backend, self.scene, self.findings, self.checked = backend, scene, findings, checked
        n = len(scene.requests)
        self.ticks: list[Tick] = []
        self.begun = [0] * n  # per robot: contacts seen to begin, from collided
        self.touch_s = [0.0] * n  # contact time seen, from collided
        self.touching = [False] * n
        self.last: list[ContactStats | None] = [None] * n

    def _fail(self, key: str, sentence: str) -> None:
        self.findings.setdefault(key, sentence)  # a problem is said once, at the first tick it shows

    def history(self) -> list[Tick] | None:
        """Every tick's readings, poses and contacts; None when a call failed (said in the findings)."""
        s, backend = self.scene, self.backend
        try:
            _call("open()", backend.open, s.world, list(s.requests), s.dt_s, s.seed)
            try:
                for t in range(s.ticks):
                    self._tick(t)
                if self.checked:
                    self._refusals()
            except BaseException:
                with contextlib.suppress(Exception):  # the failure that ended the run is the one to say
                    backend.close()
                raise
            if self.checked:
                self._close()
            else:
                _call("close()", backend.close)
        except _Abort as e:
            self._fail(f"abort:{e}", str(e))
            return None
        return self.ticks

    def _tick(self, t: int) -> None:
        backend, n = self.backend, len(self.scene.requests)
        readings = self._shaped(t, _call(f"sense() at tick {t}", backend.sense))
        poses = tuple(_call(f"pose({i}) at tick {t}", backend.pose, i) for i in range(n))
        contacts = tuple(_call(f"contacts({i}) at tick {t}", backend.contacts, i) for i in range(n))
        tick = Tick(readings, poses, contacts)
        self.ticks.append(tick)
        if self.checked:
            self._check(t, tick)
        self._send(t)
        _call(f"step() at tick {t}", backend.step)

    def _shaped(self, t: int, readings: object) -> tuple[tuple[object, ...], ...]:
        """sense()'s lists as frozen rows; a run whose readings have the wrong shape cannot go on."""
        requests = self.scene.requests
        if not isinstance(readings, list) or len(readings) != len(requests):
            raise _Abort(f"sense() returned {show(readings)} at tick {t}; it must return a list holding one "
                         f"list per robot ({len(requests)} here)")
        rows = []
        for req, row in zip(requests, readings):
            if not isinstance(row, list) or len(row) != len(req.channels):
                raise _Abort(f"sense() returned {show(row)} for robot '{req.name}' at tick {t}; it must be a list "
                             f"of one value per channel the robot asked for, in order ({', '.join(req.channels)})")
            rows.append(tuple(_freeze(v) for v in row))
        return tuple(rows)

    def _send(self, t: int) -> None:
        """The commands of tick t. The first wheeled robot drives at full speed (5 rad/s at most),
        backs off from tick 40 to 59 and drives on again; the others arc left, then spin from
        tick 50. A mechanism's joints follow ``_joint_commands``."""
        s, backend = self.scene, self.backend
        wheeled = 0
        for i, req in enumerate(s.requests):
            if req.model is None:
                for joint, mode, value in _joint_commands(s.world, t, s.ticks):
                    _call(f"command({i}, {joint!r}, {mode!r}, {value}) at tick {t}", backend.command, i, joint,
                          mode, value)
                continue
            top = req.model.max_wheel_speed_rad_s
            if wheeled == 0:
                left = right = min(5.0, top) * (-1.0 if 40 <= t < 60 else 1.0)
            else:
                left, right = min(2.0, top) * (1.0 if t < 50 else -1.0), min(2.0, top)
            wheeled += 1
            _call(f"act({i}, {left}, {right}) at tick {t}", backend.act, i, left, right)

    # --- what a checked run checks ----------------------------------------------------------------

    def _check(self, t: int, tick: Tick) -> None:
        s = self.scene
        for i, req in enumerate(s.requests):
            row = dict(zip(req.channels, tick.readings[i]))
            for channel, value in row.items():
                self._check_value(t, i, req, channel, value)
            self._check_pose(t, i, req, row, tick.poses[i])
            self._check_contacts(t, i, req, row, tick.contacts[i])

    def _check_value(self, t: int, i: int, req: RobotRequest, channel: str, value: object) -> None:
        spec = self.scene.specs[i].get(channel)
        where = f"robot '{req.name}' channel '{channel}' at tick {t}"
        wrong = _wrong(self.scene.kinds[i][channel], value, spec)
        if wrong is not None:
            self._fail(f"value:{req.name}:{channel}", f"sense() read {show(value)} for {where}; it must be {wrong}")
        elif isinstance(spec, Sonar) and isinstance(value, float) and spec.range_m * (1 + TOLERANCE) < value < math.inf:
            self._fail(f"range:{req.name}:{channel}",
                       f"sense() read {value} m for {where}, beyond the sonar's range_m of {spec.range_m}; "
                       "a sonar that detects nothing within its range reads math.inf")

    def _check_pose(self, t: int, i: int, req: RobotRequest, row: dict[str, object], pose: object) -> None:
        """pose() is a robot's pose now, as x, y, heading read it (a heading checked here is
        checked in the readings too: they must agree)."""
        if not (isinstance(pose, tuple) and len(pose) == 3 and all(_finite(v) for v in pose)):
            self._fail(f"pose:{i}", f"pose({i}) returned {show(pose)} at tick {t}; it must be a tuple "
                                    "(x_m, y_m, heading_rad) of three finite floats")
            return
        if req.model is not None and not -math.pi < pose[2] <= math.pi:
            self._fail(f"pose-heading:{i}", f"pose({i}) returned the heading {pose[2]} at tick {t}; a heading "
                                            "is in radians, in (-pi, pi]")
        read = [(c, p, row[c]) for c, p in zip(("x", "y", "heading"), pose) if c in row]
        if any(not isinstance(v, (int, float)) or not math.isclose(p, v, rel_tol=TOLERANCE, abs_tol=TOLERANCE)
               for _, p, v in read):
            said = ", ".join(f"{c} = {v!r}" for c, _, v in read)
            self._fail(f"pose-agrees:{i}", f"pose({i}) returned {show(pose)} at tick {t}, but sense() read {said} "
                                           f"for robot '{req.name}' in the same tick; both tell where it is now")

    def _check_contacts(self, t: int, i: int, req: RobotRequest, row: dict[str, object], stats: object) -> None:
        """Contacts follow collided: a tick on which it turns True begins a contact (a simulator
        may also count one that began and ended within a step), and each tick after the first
        that reads True adds dt_s of contact time. A mechanism's parts touch by design: it
        reads no collision and no contacts."""
        where = f"contacts({i}) returned {show(stats)} at tick {t}"
        if not (isinstance(stats, ContactStats) and _count(stats.count, whole=True) and _count(stats.time_s)):
            self._fail(f"contacts:{i}", f"{where}; it must be a ContactStats(count, time_s): an int >= 0 and "
                                        "a number of seconds >= 0")
            return
        last, self.last[i] = self.last[i], stats
        if last is not None and (stats.count < last.count or stats.time_s < last.time_s):
            self._fail(f"contacts-down:{i}", f"{where}, after {last}; contacts are counted since open() and "
                                             "never go down")
        collided = row.get("collided")
        if req.model is None:
            if stats != ContactStats(0, 0.0) or collided not in (None, False):
                self._fail(f"mechanism:{i}", f"{where} and collided read {collided!r} for the mechanism "
                                             f"'{req.name}'; a mechanism's parts touch by design, so it reads "
                                             "collided False and ContactStats(0, 0.0)")
            return
        if not isinstance(collided, bool):
            return  # not asked for (or said already)
        self.begun[i] += collided and not self.touching[i]
        self.touch_s[i] += self.scene.dt_s if collided and t > 0 else 0.0
        self.touching[i] = collided
        if stats.count < self.begun[i]:
            self._fail(f"contacts-count:{i}", f"{where}, but collided has turned True {self.begun[i]} time(s) "
                                              f"for robot '{req.name}'; each time it turns True a contact begins")
        if abs(stats.time_s - self.touch_s[i]) > TOLERANCE:
            self._fail(f"contacts-time:{i}", f"{where}, but collided has read True on ticks worth "
                                             f"{self.touch_s[i]:.6g} s for robot '{req.name}'; each tick after "
                                             "the first that reads True adds dt_s of contact time")

    def _refusals(self) -> None:
        """A command the scene cannot carry out raises BackendError: an unknown joint of a
        mechanism, any joint of a wheeled robot."""
        for i, req in enumerate(self.scene.requests):
            done = _fails_with(BackendError, partial(self.backend.command, i, "no_such_joint", "velocity", 0.0))
            if done:
                self._fail(f"refuse:{i}", f"command({i}, 'no_such_joint', 'velocity', 0.0) {done} for robot "
                                          f"'{req.name}', which has no such joint; a command the scene cannot carry "
                                          "out must raise labsim.backends.protocol.BackendError, with a message "
                                          "for the user")

    def _close(self) -> None:
        """close() twice; then every call but contacts raises BackendStateError, and contacts
        still read what they read before close (a run's summary reads them)."""
        backend, n = self.backend, len(self.scene.requests)
        before = [_call(f"contacts({i}) before close()", backend.contacts, i) for i in range(n)]
        _call("close()", backend.close)
        twice = _fails_with(None, backend.close)
        if twice:
            self._fail("close-twice", f"close() a second time {twice}; close() must be safe to call twice (a run "
                                      "closes its backend however it ends)")
        check_shut(backend, "after close()", self.findings)
        for i in range(n):
            after = _call(f"contacts({i}) after close()", backend.contacts, i)
            if after != before[i]:
                self._fail(f"contacts-closed:{i}", f"contacts({i}) returned {show(after)} after close() but "
                                                   f"{show(before[i])} before; a run's summary reads contacts "
                                                   "after close(), so they stay as they were")


def _joint_commands(world: World, t: int, ticks: int) -> list[tuple[str, str, float]]:
    """A mechanism's commands at tick t: every motorised joint that takes velocities is sent half
    its top speed at tick 0; a third of the way through, every one that takes positions is sent
    the middle of its limits (its start position when it has none)."""
    mechanism = world.mechanism
    assert mechanism is not None  # _scene lets a request without a model into a mechanism's world only
    out = []
    for name, modes in mechanism.motor_modes().items():
        joint = mechanism.joint(name)
        if joint.motor is None:
            continue
        if t == 0 and "velocity" in modes:
            out.append((name, "velocity", 0.5 * joint.motor.max_speed))
        if t == ticks // 3 and "position" in modes:
            lo_hi = joint.limits
            out.append((name, "position", (lo_hi[0] + lo_hi[1]) / 2 if lo_hi else mechanism.initial_position(joint)))
    return out


def check_shut(backend: Backend, when: str, findings: dict[str, str]) -> None:
    """Before open() (and after close(), where contacts stay readable) every call raises BackendStateError."""
    calls: dict[str, Callable[[], object]] = {
        "sense()": lambda: backend.sense(),
        "act(0, 0.0, 0.0)": lambda: backend.act(0, 0.0, 0.0),
        "command(0, 'joint', 'velocity', 0.0)": lambda: backend.command(0, "joint", "velocity", 0.0),
        "step()": lambda: backend.step(),
        "pose(0)": lambda: backend.pose(0),
    }
    if when == "before open()":
        calls["contacts(0)"] = lambda: backend.contacts(0)
    for call, run in calls.items():
        done = _fails_with(BackendStateError, run)
        if done:
            findings.setdefault(f"shut:{when}:{call}", f"{call} {when} {done}; a call in the wrong order must "
                                                       "raise labsim.backends.protocol.BackendStateError")


def _fails_with(error: type[Exception] | None, call: Callable[[], object]) -> str:
    """What ``call`` did wrong, as words ("returned", "raised KeyError (...)"): it must raise
    ``error``, or return when ``error`` is None; "" when it did."""
    try:
        call()
    except Exception as e:
        if error is not None and isinstance(e, error):
            return ""
        return f"raised {type(e).__name__} ({e})" + (f" instead of {error.__name__}" if error else "")
    return f"returned instead of raising {error.__name__}" if error else ""


# --- values ------------------------------------------------------------------------------------

def _wrong(kind: Kind, value: object, spec: Sonar | Camera | None) -> str | None:
    """What a channel's value must be, when it is not; None when it is."""
    if kind is Kind.IMAGE:
        shape = (spec.height_px, spec.width_px, 3) if isinstance(spec, Camera) else None
        if isinstance(value, _Image) and value.dtype == "uint8" and (
                value.shape == shape if shape else len(value.shape) == 3 and value.shape[2] == 3):
            return None
        return f"an RGB image: a uint8 array of shape {shape or '(height, width, 3)'}, row 0 the bottom"
    if kind in (Kind.BOOL, Kind.CONTACT):
        ok = isinstance(value, bool)
    elif kind is Kind.REFLECTANCE:
        ok = _finite(value) and 0.0 <= value <= 1.0  # type: ignore[operator]
    elif kind in _TUPLE_SIZES:
        ok = (isinstance(value, tuple) and len(value) == _TUPLE_SIZES[kind] and all(_finite(v) for v in value)
              and (kind is not Kind.FORCE or value[0] >= 0))
    elif kind is Kind.DISTANCE:
        ok = isinstance(value, float) and (value == math.inf or (_finite(value) and value >= 0))
    else:
        ok = _finite(value) or (isinstance(value, int) and not isinstance(value, bool))
    return None if ok else _TYPES[kind]


def _finite(value: object) -> bool:
    return isinstance(value, float) and math.isfinite(value)


def _count(value: object, whole: bool = False) -> bool:
    """A count (``whole``: an int) or a time (an int or a float) >= 0, not a bool."""
    if isinstance(value, bool) or not isinstance(value, int if whole else (int, float)):
        return False
    return 0 <= value < math.inf


def _freeze(value: object) -> object:
    """A reading as it is now: an image's array becomes its bytes (a backend may reuse it)."""
    if isinstance(value, tuple):
        return tuple(_freeze(v) for v in value)
    shape, tobytes = getattr(value, "shape", None), getattr(value, "tobytes", None)
    if isinstance(shape, tuple) and shape and callable(tobytes):
        return _Image(shape, str(getattr(value, "dtype", "")), tobytes())
    return value


def show(value: object) -> str:
    """A value as a message shows it: an image by its shape, anything else by a short repr."""
    if isinstance(value, _Image):
        return f"an array of shape {value.shape} and dtype {value.dtype}"
    text = repr(value)
    return text if len(text) <= 80 else text[:77] + "..."
