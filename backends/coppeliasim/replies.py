"""The coppeliasim backend's replies, checked: every value a server sends is what CoppeliaSim sends.

Where it sits: ``connection.Connection.call`` hands each reply here before the backend uses
it. Anything on the port may answer (a CoppeliaSim of another version, a proxy, a program that
only speaks the protocol), and a reply of the wrong shape would otherwise end the run in a
``TypeError`` deep in ``fleet``, or a NaN distance would make a stop condition never hold.
So each function the backend calls has the shape its reply has in CoppeliaSim's API
reference (4.6 to 4.9, the ``regularApi`` calltips, cited per row), and a reply that does not
fit is a ``BackendError`` naming the function, the object and what came back (shortened).

How the client hands a reply on: a reply of one value comes as that value, of several as a
tuple (``coppeliasim_zmqremoteapi_client`` 2.0.4). Numbers are finite where CoppeliaSim's are
(positions, distances, joint states, times: it never sends NaN or infinity for them); a CBOR
integer is accepted where a float is documented, since CoppeliaSim's encoder sends ``0.0`` as
whatever is shortest.
"""
from __future__ import annotations

import math
from collections.abc import Callable

from labsim.backends.protocol import BackendError
from labsim.foundation.numbers import NumberError, to_float

SHOWN = 80  # characters of a bad reply quoted in the error


class Shape(Exception):
    """A reply does not fit: what was expected (caught and turned into a BackendError)."""


def _number(v: object, what: str = "a number") -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise Shape(what)
    try:  # the one rule for numbers: an integer too large for a float is refused, not an OverflowError
        f = to_float(v)
    except NumberError:
        raise Shape(f"{what} (a number too large for a float)") from None
    if not math.isfinite(f):
        raise Shape(f"{what} (CoppeliaSim never sends {f!r} there)")
    return f


def _integer(v: object, what: str = "an integer") -> int:
    if not isinstance(v, int):  # CBOR true/false are ints to Python; CoppeliaSim's flags may be either
        raise Shape(what)
    return int(v)


def _vector(v: object, n: int = 3, what: str = "") -> list[float]:
    what = what or f"a list of {n} numbers"
    if not isinstance(v, (list, tuple)) or len(v) != n:
        raise Shape(what)
    return [_number(x, what) for x in v]


def _values(v: object, n: int, what: str) -> tuple[object, ...]:
    """A reply of ``n`` values (the client's tuple); more are allowed, as later versions add some."""
    if not isinstance(v, (list, tuple)) or len(v) < n:
        raise Shape(what)
    return tuple(v)


def _proximity(v: object) -> object:
    # int result, float distance, float[3] detectedPoint, int detectedObjectHandle,
    # float[3] detectedSurfaceNormalVector = sim.readProximitySensor(int sensorHandle): 4.6
    what = "(result, distance, point, object, normal)"
    res, dist, point, obj, normal = _values(v, 5, what)[:5]
    _integer(res, what)
    if _number(dist, what) < 0:
        raise Shape(f"{what} with a distance >= 0")
    _vector(point, 3, what)
    _integer(obj, what)
    _vector(normal, 3, what)
    return v


def _collision(v: object) -> object:
    # int result, int[2] collidingObjects = sim.checkCollision(int entity1, int entity2): 4.6
    # (4.0 to 4.2 answered the result alone)
    if isinstance(v, (list, tuple)):
        what = "(result, [object, object])"
        res, pair = _values(v, 2, what)[:2]
        if not isinstance(pair, (list, tuple)):
            raise Shape(what)
        _integer(res, what)
        return v
    return _integer(v, "(result, [object, object])")


def _image(v: object) -> object:
    # buffer image, int[2] resolution = sim.getVisionSensorImg(int sensorHandle, ...): 4.6;
    # options 0: RGB, 3 bytes a pixel, the sensor's resolution
    what = "(RGB bytes, [width, height])"
    img, res = _values(v, 2, what)[:2]
    if not isinstance(img, (bytes, bytearray)) or not isinstance(res, (list, tuple)) or len(res) != 2:
        raise Shape(what)
    w, h = (_integer(n, what) for n in res)
    if w <= 0 or h <= 0 or len(img) != 3 * w * h:
        raise Shape(f"{what}, 3 x width x height bytes")
    return v


def _velocity(v: object) -> object:
    # float[3] linearVelocity, float[3] angularVelocity = sim.getObjectVelocity(int objectHandle): 4.6
    what = "([vx, vy, vz], [wx, wy, wz])"
    lin, ang = _values(v, 2, what)[:2]
    _vector(lin, 3, what)
    _vector(ang, 3, what)
    return v


def _force(v: object) -> object:
    # int result, float[3] forceVector, float[3] torqueVector = sim.readForceSensor(int objectHandle): 4.6
    what = "(result, [fx, fy, fz], [tx, ty, tz])"
    res, force, torque = _values(v, 3, what)[:3]
    _integer(res, what)
    _vector(force, 3, what)
    _vector(torque, 3, what)
    return v


def _handle(v: object) -> object:
    return _integer(v, "an object handle (an integer)")


def _finite(v: object) -> object:
    return _number(v, "a finite number")


# What each function the backend calls answers (CoppeliaSim 4.6 API reference). A function
# not listed here is not read (sim.step, sim.setJointTargetVelocity, ...).
CHECKS: dict[str, Callable[[object], object]] = {
    "sim.readProximitySensor": _proximity,
    "sim.checkCollision": _collision,
    "sim.getVisionSensorImg": _image,
    "sim.getObjectVelocity": _velocity,
    "sim.readForceSensor": _force,
    # float[3] position = sim.getObjectPosition(int objectHandle, int relativeToObjectHandle): 4.6
    "sim.getObjectPosition": lambda v: _vector(v, 3, "[x, y, z]"),
    # float[3] eulerAngles = sim.getObjectOrientation(int objectHandle, int relativeToObjectHandle): 4.6
    "sim.getObjectOrientation": lambda v: _vector(v, 3, "[alpha, beta, gamma]"),
    "sim.getJointPosition": _finite,  # float position = sim.getJointPosition(int objectHandle): 4.6
    "sim.getJointVelocity": _finite,  # float velocity = sim.getJointVelocity(int jointHandle): 4.6
    "sim.getSimulationTime": _finite,  # float simulationTime = sim.getSimulationTime(): 4.6
    "sim.getSimulationState": lambda v: _integer(v, "a simulation state (an integer)"),
    "sim.getObject": _handle,  # int objectHandle = sim.getObject(string path, map options = {}): 4.6
}


def check(func: str, reply: object, obj: str) -> object:
    """``reply`` if it has the shape ``func``'s reply has in CoppeliaSim, else a BackendError
    naming ``func``, the object ``obj`` it was about ("" for none) and what came back."""
    checker = CHECKS.get(func)
    if checker is None:
        return reply
    try:
        checker(reply)
    except Shape as e:
        raise BackendError(mismatch(func, reply, obj, str(e))) from None
    except (TypeError, ValueError):  # a tuple of the wrong length to unpack
        raise BackendError(mismatch(func, reply, obj, "")) from None
    return reply


def mismatch(func: str, reply: object, obj: str, expected: str) -> str:
    """The message for a reply that is not what CoppeliaSim sends."""
    on = f" for {obj}" if obj else ""
    want = f"; CoppeliaSim answers {expected}" if expected else ""
    return f"{func}{on} answered {shorten(reply)}, which CoppeliaSim never sends{want}"


def shorten(value: object) -> str:
    """``repr(value)`` cut to ``SHOWN`` characters (an image is thousands of bytes)."""
    text = repr(value)
    return text if len(text) <= SHOWN else text[:SHOWN - 3] + "..."


def _seq(v: object, what: str) -> list[object]:
    """A Lua array: a list, or an empty table (which a CBOR encoder may send as an empty map)."""
    if isinstance(v, (list, tuple)):
        return list(v)
    if isinstance(v, dict) and not v:
        return []
    raise Shape(what)


def check_sense(reply: object, robots: list[str], plan: list[list[object]]) -> list[list[object]]:
    """The fleet script's ``labsimSense`` reply (``fleet_script``), each robot's entry checked as
    the per-object calls' replies are; ``robots`` names them, ``plan`` is what was asked."""
    func = "sim.callScriptFunction('labsimSense')"
    try:
        entries = _seq(reply, f"a list of {len(plan)} robots' readings")
        if len(entries) != len(plan):
            raise Shape(f"a list of {len(plan)} robots' readings")
    except Shape as e:
        raise BackendError(mismatch(func, reply, "the fleet", str(e))) from None
    out: list[list[object]] = []
    for entry, name, asked in zip(entries, robots, plan):
        try:
            out.append(_robot_readings(entry, asked))
        except (Shape, BackendError) as e:
            raise BackendError(mismatch(func, entry, f"robot '{name}'", str(e))) from None
    return out


def _robot_readings(entry: object, asked: list[object]) -> list[object]:
    what = "[sonars, images, position, orientation, velocity, collision]"
    parts = _seq(entry, what)
    if len(parts) != 6:
        raise Shape(what)
    sonars, images = _seq(parts[0], what), _seq(parts[1], what)
    flags, sonar_handles, camera_handles = asked[2], asked[3], asked[4]
    assert isinstance(flags, int) and isinstance(sonar_handles, list) and isinstance(camera_handles, list)
    if len(sonars) != len(sonar_handles) or len(images) != len(camera_handles):
        raise Shape(f"{what}, a reading for each sonar and camera asked for")
    for one in sonars:
        _proximity(one)
    for one in images:
        _image(one)
    read = [CHECKS["sim.getObjectPosition"], CHECKS["sim.getObjectOrientation"], _velocity]
    kept: list[object] = []
    for bit, part, checker in zip((1, 2, 4), parts[2:5], read):
        if flags & bit:
            checker(part)
        kept.append(part if flags & bit else [])
    _collision(parts[5])
    return [sonars, images, *kept, parts[5]]


def check_parts(reply: object, name: str, plan: list[list[int]]) -> list[list[object]]:
    """The fleet script's ``labsimParts`` reply for the mechanism ``name``: for each joint of
    ``plan[0]`` (position, velocity), each force sensor of ``plan[1]`` readForceSensor's reply,
    each body of ``plan[2]`` (position, orientation), checked as the per-object replies are."""
    func = "sim.callScriptFunction('labsimParts')"
    what = "[[position, velocity] per joint, a force reading per sensor, [position, orientation] per body]"
    try:
        parts = _seq(reply, what)
        if len(parts) != 3:
            raise Shape(what)
        joints, forces, bodies = (_seq(part, what) for part in parts)
        if (len(joints), len(forces), len(bodies)) != tuple(len(p) for p in plan):
            raise Shape(f"{what}, one for each part asked for")
        for one in joints:
            pair = _values(one, 2, what)
            _number(pair[0], what), _number(pair[1], what)
        for one in forces:
            _force(one)
        for one in bodies:
            pair = _values(one, 2, what)
            _vector(pair[0], 3, what), _vector(pair[1], 3, what)
    except Shape as e:
        raise BackendError(mismatch(func, reply, f"'{name}'", str(e))) from None
    return [joints, forces, bodies]
