"""The stand-in's scene tree: CoppeliaSim's objects, their aliases and its path language.

Where it sits: ``labsim serve`` (``server``) answers ``sim.getObject`` and friends
(``sim_api``) from this tree; the simulation (``simulation``) builds it once, for the robots
and the mechanism it serves, and never changes it. Nothing here simulates or talks to the
wire: it is names, handles and parents.

What the tree holds, for each Pioneer P3DX robot ``i`` (``/PioneerP3DX[i]`` in the order
given): ``leftMotor``, ``rightMotor``, 16 ``ultrasonicSensor`` children and, when its model has
cameras, a vision sensor (``Vision_sensor`` for the channel ``camera``, as 4.6 and 4.7 name it, also
answering to 4.8's ``visionSensor``); for a world with a
mechanism (the crane), its joints (all but fixed ones), force sensors and moving bodies at
the top level, by their names. Handles are 1, 2, 3, ... in the order objects are added.

The path language is CoppeliaSim's (manual: "Accessing scene objects programmatically"):
``/A/B`` from the top, ``[n]`` the n-th same-alias object of the first level below that has
one, ``{n}`` the n-th match anywhere below, level by level, ``*`` and ``?`` wildcards, ``.``,
``..``, ``:``, ``./x`` and ``:/x`` relative to a proxy object, and the ``index`` option. The
names before CoppeliaSim 4.3 (``Pioneer_p3dx_ultrasonicSensor5``, ``#0`` for the second robot)
are kept apart (``old_name``): CoppeliaSim 4.6 documents paths for ``sim.getObject`` and old
names only for the deprecated ``sim.getObjectHandle``.
"""
from __future__ import annotations

from dataclasses import dataclass, field

from labsim.backends.coppeliasim import CAMERA_ALIASES, camera_alias
from labsim.backends.protocol import BackendError
from labsim.backends.scene.mechanism import Mechanism
from labsim.backends.scene.models import PIONEER_P3DX, Kind, RobotModel
from labsim.runtime.serve.wire_limits import Deadline

ROBOT_Z_M = PIONEER_P3DX.wheel_radius_m  # the robot frame's origin: the wheel axle, above the floor
SONAR_Z_M = 0.1  # nominal mount heights above the robot origin; the scene is flat

MAX_INDEX_DIGITS = 9  # [n] and {n}: no scene has a billion objects
_KINDS = {Kind.JOINT: "joint", Kind.FORCE: "force", Kind.BODY: "body"}


@dataclass(eq=False)
class SceneObject:
    """A scene object: what sim.getObject hands out a handle for."""

    handle: int
    alias: str
    kind: str  # robot | motor | sonar | camera | bumper | ground | joint | force | body
    parent: SceneObject | None = None
    children: list[SceneObject] = field(default_factory=list)
    robot: int = -1  # the robot it belongs to
    index: int = -1  # sonar number - 1; motor side (0 left, 1 right)
    name: str = ""  # channel, joint, force sensor or body name
    mount: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)  # x, y, z, yaw in the parent frame
    resolution: tuple[int, int] = (0, 0)  # vision sensors: (resX, resY)
    also: tuple[str, ...] = ()  # other aliases it answers to in paths (one name set: docs/coppeliasim.md)


class SceneTree:
    """Objects by handle, the top level in order, and the pre-4.3 names."""

    def __init__(self) -> None:
        self.objects: dict[int, SceneObject] = {}
        self.top: list[SceneObject] = []
        self._old_names: dict[str, SceneObject] = {}

    # --- building ----------------------------------------------------------------------------

    def add(self, obj: SceneObject) -> SceneObject:
        """Give ``obj`` the next handle and put it last among its parent's children."""
        obj.handle = len(self.objects) + 1
        self.objects[obj.handle] = obj
        (obj.parent.children if obj.parent is not None else self.top).append(obj)
        return obj

    def add_robot(self, i: int, model: RobotModel) -> SceneObject:
        """Robot ``i``'s objects, as CoppeliaSim's model of it names them; its base."""
        if model.name == "epuck":
            return self.add_epuck(i, model)
        if model.name != "pioneer_p3dx":
            raise BackendError(f"labsim serve: no CoppeliaSim scene names for robot model '{model.name}'")
        return self.add_pioneer(i, model)

    def add_epuck(self, i: int, model: RobotModel) -> SceneObject:
        """An e-puck's objects, by the names of CoppeliaSim's stock e-puck (its script's
        ``ePuck_leftJoint``, ``ePuck_proxSensor1..8``, ``ePuck_camera``), and labsim's
        ``ePuck_groundSensor1..3`` for its ground sensors (the stock model has none)."""
        add = self.add
        base = add(SceneObject(0, "ePuck", "robot", None, robot=i))
        half = model.axle_length_m / 2
        add(SceneObject(0, "ePuck_leftJoint", "motor", base, robot=i, index=0, mount=(0.0, half, 0.0, 0.0)))
        add(SceneObject(0, "ePuck_rightJoint", "motor", base, robot=i, index=1, mount=(0.0, -half, 0.0, 0.0)))
        for k, s in enumerate(model.sonars):
            add(SceneObject(0, f"ePuck_proxSensor{k + 1}", "sonar", base, robot=i, index=k, name=s.name,
                            mount=(s.x_m, s.y_m, 0.01, s.angle_rad)))
        for c in model.cameras:
            add(SceneObject(0, camera_alias(model.name, c.name), "camera", base, robot=i, name=c.name,
                            mount=(c.x_m, 0.0, c.height_m - model.wheel_radius_m, 0.0),
                            resolution=(c.width_px, c.height_px)))
        self._add_contacts_and_ground(i, model, base, "ePuck_groundSensor")
        return base

    def _add_contacts_and_ground(self, i: int, model: RobotModel, base: SceneObject, ground: str) -> None:
        """A model's bumpers (``bumper_front_left`` ..: proximity sensors) and ground sensors
        (``{ground}1`` ..: vision sensors one pixel wide), under its base."""
        for b in model.bumpers:
            self.add(SceneObject(0, b.name.replace("bump_", "bumper_"), "bumper", base, robot=i, name=b.name,
                                 mount=(b.x_m, b.y_m, 0.0, 0.0)))
        for k, g in enumerate(model.ground_sensors):
            self.add(SceneObject(0, f"{ground}{k + 1}", "ground", base, robot=i, name=g.name,
                                 mount=(g.x_m, g.y_m, 0.0, 0.0), resolution=(1, 1)))

    def add_pioneer(self, i: int, model: RobotModel) -> SceneObject:
        """Robot ``i``'s objects, as CoppeliaSim's Pioneer P3DX model names them; its base."""
        add = self.add
        base = add(SceneObject(0, "PioneerP3DX", "robot", None, robot=i))
        half = model.axle_length_m / 2
        left = add(SceneObject(0, "leftMotor", "motor", base, robot=i, index=0, mount=(0.0, half, 0.0, 0.0)))
        right = add(SceneObject(0, "rightMotor", "motor", base, robot=i, index=1, mount=(0.0, -half, 0.0, 0.0)))
        sonars = [add(SceneObject(0, "ultrasonicSensor", "sonar", base, robot=i, index=k, name=s.name,
                                  mount=(s.x_m, s.y_m, SONAR_Z_M, s.angle_rad)))
                  for k, s in enumerate(model.sonars)]
        for c in model.cameras:
            alias = camera_alias(model.name, c.name)
            add(SceneObject(0, alias, "camera", base, robot=i, name=c.name,
                            mount=(c.x_m, 0.0, c.height_m - ROBOT_Z_M, 0.0),
                            resolution=(c.width_px, c.height_px),
                            also=tuple(a for a in CAMERA_ALIASES if a != alias and alias in CAMERA_ALIASES)))
        self._add_contacts_and_ground(i, model, base, "groundSensor")
        # The names of V-REP and CoppeliaSim before 4.3 (sim.getObjectHandle), with #n for
        # the second robot on: old scripts still use them.
        suffix = "" if i == 0 else f"#{i - 1}"
        self._old_names[f"Pioneer_p3dx{suffix}"] = base
        self._old_names[f"Pioneer_p3dx_leftMotor{suffix}"] = left
        self._old_names[f"Pioneer_p3dx_rightMotor{suffix}"] = right
        for k, s in enumerate(sonars):
            self._old_names[f"Pioneer_p3dx_ultrasonicSensor{k + 1}{suffix}"] = s
        return base

    def add_mechanism(self, mechanism: Mechanism) -> list[str]:
        """A mechanism's joints (all but fixed ones), force sensors and moving bodies, at the
        top level by their names; returns those names, which are its channels, in order."""
        channels = list(mechanism.channels().items())
        for name, kind in channels:
            self.add(SceneObject(0, name, _KINDS[kind], None, name=name))
        return [name for name, _ in channels]

    # --- reading -----------------------------------------------------------------------------

    def top_level(self, kind: str) -> list[SceneObject]:
        return [o for o in self.top if o.kind == kind]

    def named(self, name: str) -> SceneObject:
        """The top-level mechanism part called ``name``."""
        return next(o for o in self.top if o.name == name)

    def _siblings(self, obj: SceneObject) -> list[SceneObject]:
        return obj.parent.children if obj.parent is not None else self.top

    def path(self, obj: SceneObject, short: bool = False) -> str:
        """``/PioneerP3DX[0]/ultrasonicSensor[4]``; ``short`` leaves out ``[0]`` of an only one."""
        parts = []
        o: SceneObject | None = obj
        while o is not None:
            same = [s for s in self._siblings(o) if s.alias == o.alias]
            parts.append(f"{o.alias}[{same.index(o)}]" if len(same) > 1 or not short else o.alias)
            o = o.parent
        return "/" + "/".join(reversed(parts))

    def alias(self, obj: SceneObject, options: int) -> str:
        """sim.getObjectAlias: -1 the alias, 0 with its index, 1 and 5 the short path,
        3 and 4 alias and handle, anything else the full path."""
        if options == -1:
            return obj.alias
        if options == 0:
            return f"{obj.alias}[{[s for s in self._siblings(obj) if s.alias == obj.alias].index(obj)}]"
        if options in (1, 5):
            return self.path(obj, short=True)
        if options in (3, 4):
            return f"{obj.alias}__{obj.handle}__"
        return self.path(obj)

    # --- the path language -------------------------------------------------------------------

    def find(self, path: str, index: int, proxy: SceneObject | None) -> SceneObject | None:
        """sim.getObject's rules (see the module docstring); None when nothing matches."""
        if path.startswith("/"):
            return self._walk(None, path[1:], index)
        if path in (".", "..", ":") or path.startswith(("./", ":/")):
            if proxy is None:
                return None  # relative paths need a proxy object: a remote client has no script
            if path == ".":
                return proxy
            if path == "..":
                return proxy.parent
            model = proxy
            while model.parent is not None:
                model = model.parent
            if path == ":":
                return model
            return self._walk(proxy if path.startswith("./") else model, path[2:], index)
        return None  # not a path: an old name is sim.getObjectHandle's (old_name)

    def old_name(self, name: str) -> SceneObject | None:
        """The object a name from before CoppeliaSim 4.3 meant (``Pioneer_p3dx_leftMotor#0``)."""
        return self._old_names.get(name)

    def _walk(self, base: SceneObject | None, rest: str, index: int) -> SceneObject | None:
        """Follow the segments of ``rest`` down from ``base`` (None: the top)."""
        if not rest:
            return base
        segments = rest.split("/")
        for n, seg in enumerate(segments):
            parsed = _segment(seg)
            if parsed is None:
                return None
            pattern, sib, anywhere = parsed
            level = base.children if base is not None else self.top
            last = n == len(segments) - 1
            if anywhere is not None or (last and index >= 0 and sib is None):
                # {n} or the index option: the n-th match anywhere below, level by level
                found = _nth_below(level, pattern, anywhere if anywhere is not None else index)
            else:
                # alias[n]: the n-th match among the first level below that has any
                found = _nth_at_first_level(level, pattern, sib or 0)
            if found is None:
                return None
            base = found
        return base


def _segment(seg: str) -> tuple[str, int | None, int | None] | None:
    """``alias``, ``alias[n]`` or ``alias{n}`` -> (alias pattern, n of [n], n of {n}); None
    when ill formatted. Read by hand, in one pass."""
    sib = anywhere = None
    if seg.endswith(("]", "}")):
        opening = "[" if seg[-1] == "]" else "{"
        start = seg.rfind(opening)
        digits = seg[start + 1:-1]
        if start < 0 or not digits.isdigit() or not digits.isascii() or len(digits) > MAX_INDEX_DIGITS:
            return None
        if opening == "[":
            sib = int(digits)
        else:
            anywhere = int(digits)
        seg = seg[:start]
    if not seg or any(c in "[]{}" for c in seg):
        return None
    return seg, sib, anywhere


def glob_match(pattern: str, text: str) -> bool:
    """Whether ``text`` matches ``pattern`` whole, ``*`` standing for any run of characters and
    ``?`` for any one, as in CoppeliaSim's paths.

    Two pointers and one remembered star, never backtracking further: at most
    len(pattern) x len(text) steps. (A regular expression of ``.*``s, as this used to be,
    backtracks exponentially: sixteen stars and a Z never finished.)"""
    p = t = 0
    star, resume = -1, 0  # the last star seen, and where in text its run ends so far
    while t < len(text):
        if p < len(pattern) and (pattern[p] == "?" or pattern[p] == text[t]):
            p += 1
            t += 1
        elif p < len(pattern) and pattern[p] == "*":
            star, resume = p, t
            p += 1
        elif star >= 0:  # let the last star swallow one more character
            resume += 1
            p, t = star + 1, resume
        else:
            return False
    return all(c == "*" for c in pattern[p:])


def _matches(level: list[SceneObject], pattern: str) -> list[SceneObject]:
    Deadline.check()
    return [o for o in level if glob_match(pattern, o.alias) or any(glob_match(pattern, a) for a in o.also)]


def _nth_below(level: list[SceneObject], pattern: str, k: int) -> SceneObject | None:
    found: list[SceneObject] = []
    while level and len(found) <= k:
        found += _matches(level, pattern)
        level = [c for o in level for c in o.children]
    return found[k] if k < len(found) else None


def _nth_at_first_level(level: list[SceneObject], pattern: str, k: int) -> SceneObject | None:
    while level:
        found = _matches(level, pattern)
        if found:
            return found[k] if k < len(found) else None
        level = [c for o in level for c in o.children]
    return None
