"""The stand-in's scene tree: CoppeliaSim's objects, their aliases and its path language.

Where it sits: ``labsim serve`` (``server``) answers ``sim.getObject`` and friends
(``sim_api``) from this tree; the simulation (``simulation``) builds it once, for the robots
and the mechanism it serves, and never changes it. Nothing here simulates or talks to the
wire: it is names, handles and parents.

What the tree holds, for each Pioneer P3DX robot ``i`` (``/PioneerP3DX[i]`` in the order
given): ``leftMotor``, ``rightMotor``, 16 ``ultrasonicSensor`` children and, when its model has
cameras, a vision sensor (``Vision_sensor`` for the channel ``camera``, as 4.6 and 4.7 name it,
and by that name only: a script that asks for 4.8's ``visionSensor`` is told the real name); for a world with a
mechanism (the crane), its joints (all but fixed ones), force sensors and moving bodies at
the top level, by their names. Handles are 1, 2, 3, ... in the order objects are added.

The path language is CoppeliaSim's (manual: "Accessing scene objects programmatically"),
searched as coppeliaSimLib's ``CSceneObjectContainer::getObjectFromPath`` searches: ``/A/B``
from the top (``A`` the first match at the first level that has one, depth first),
``[n]`` the n-th match of a level, ``{n}`` the n-th match of everything the path before it
reaches, ``*`` and ``?`` wildcards (each match tried in turn), ``.``, ``..``, ``:``, ``::``,
``./x`` and ``:/x`` relative to the ``proxy`` option's object or, without one (a remote
client has no emitting object), ``./x`` and ``:/x`` from the top, and the ``index`` option. The
names before CoppeliaSim 4.3 (``Pioneer_p3dx_ultrasonicSensor5``, ``#0`` for the second robot)
are kept apart (``old_name``): CoppeliaSim 4.6 documents paths for ``sim.getObject`` and old
names only for the deprecated ``sim.getObjectHandle``.
"""
from __future__ import annotations

import difflib
from dataclasses import dataclass, field

from labsim.backends.coppeliasim import camera_alias
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


class SceneTree:
    """Objects by handle, the top level in order, and the pre-4.3 names."""

    def __init__(self) -> None:
        self.objects: dict[int, SceneObject] = {}
        self.top: list[SceneObject] = []
        self._old_names: dict[str, SceneObject] = {}

    # --- building ----------------------------------------------------------------------------

    def add(self, obj: SceneObject, handle: int | None = None) -> SceneObject:
        """Give ``obj`` the next handle (or ``handle``: the one it was built with) and put it
        last among its parent's children."""
        obj.handle = handle if handle is not None and handle not in self.objects else len(self.objects) + 1
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
        # The stock model's names before CoppeliaSim 4.3 are its aliases (V-REP scripts call
        # simxGetObjectHandle('ePuck_leftJoint')), with #n for the second e-puck on.
        n = sum(1 for o in self.top if o.kind == "robot" and o.alias == "ePuck") - 1
        suffix = "" if n == 0 else f"#{n - 1}"
        for o in (base, *base.children):
            if o.kind in ("robot", "motor", "sonar", "camera") and o.alias.startswith("ePuck"):
                self._old_names[f"{o.alias}{suffix}"] = o
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
                            resolution=(c.width_px, c.height_px)))
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

    def add_mechanism(self, mechanism: Mechanism, handles: dict[str, int] | None = None) -> list[str]:
        """A mechanism's joints (all but fixed ones), force sensors and moving bodies, at the
        top level by their names; returns those names, which are its channels, in order.
        ``handles``: the handles the parts were built with (``serve --empty``), so that each
        object answers to one handle."""
        channels = list(mechanism.channels().items())
        for name, kind in channels:
            self.add(SceneObject(0, name, _KINDS[kind], None, name=name), (handles or {}).get(name))
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
        """sim.getObject's rules, as CoppeliaSim's ``getObjectFromPath`` (coppeliaSimLib,
        ``sceneObjectContainer.cpp``) applies them; None when nothing matches.

        ``proxy`` is the emitting object (the ``proxy`` option). A remote client has none: its
        calls run in the ZMQ add-on, which is no scene object, so ``./x`` and ``:/x`` search
        from the scene's top exactly as ``/x`` does, and ``.``, ``:``, ``..`` find nothing.
        ``{n}`` splits the path: the part before it is resolved with index n, the rest from
        the object found."""
        emitting = proxy
        rest = path
        while rest:
            Deadline.check()
            opening, closing = rest.find("{"), rest.find("}")
            if opening >= 0 and closing > opening + 1 and (closing != len(rest) - 1 or index == -1):
                digits = rest[opening + 1:closing]
                if digits.isdigit() and digits.isascii() and len(digits) <= MAX_INDEX_DIGITS:
                    head, rest = rest[:opening], rest[closing + 1:]
                    rest = "." + rest if rest else ""
                    found = self._simple(emitting, head, int(digits))
                    if found is None or not rest:
                        return found
                    emitting = found
                    continue
            return self._simple(emitting, rest, index)
        return None

    def _model_base(self, obj: SceneObject | None, including: bool = True) -> SceneObject | None:
        """The first object up from ``obj`` that is a model's base (a robot), itself included or not."""
        o = obj if including or obj is None else obj.parent
        while o is not None and o.kind != "robot":
            o = o.parent
        return o

    def _simple(self, emitting: SceneObject | None, path: str, index: int) -> SceneObject | None:
        """A path without ``{n}``: ``/a/b``, ``./a``, ``:/a``, ``.``, ``:``, ``../a``, ``::/a``."""
        if not path or path[0] not in "/.:":
            return None  # not a path: an old name is sim.getObjectHandle's (old_name)
        base: SceneObject | None = None
        if path[0] == "/":
            path = path[1:]
            if path[:1] in ("/", ".", ":"):
                return None
        else:
            base = emitting
            if path in (".", ":"):
                return self._model_base(base) if path == ":" else base
            if path.startswith("./"):
                path = path[2:]
            if path.startswith(":/"):
                path = path[2:]
                base = self._model_base(base)
            while path.startswith(("::", "..")):
                if base is None:
                    return None
                model = path.startswith("::")
                path = path[2:]
                if model:
                    base = self._model_base(base)
                    if base is None:
                        return None
                base = base.parent
                if model:
                    base = self._model_base(base)
                if not path:
                    return base
                if path[0] != "/":
                    return None
                path = path[1:]
        return self._in_tree(base, path, [index])

    def old_name(self, name: str) -> SceneObject | None:
        """The object a name from before CoppeliaSim 4.3 meant (``Pioneer_p3dx_leftMotor#0``)."""
        return self._old_names.get(name)

    def _in_tree(self, base: SceneObject | None, path: str, index: list[int]) -> SceneObject | None:
        """CoppeliaSim's ``_getObjectInTree``: the first segment matched among ``base``'s children
        (None: the top), each match tried with the rest of the path; objects that do not match
        (and, without ``[n]``, those that do) searched below with the whole path, depth first.
        ``alias[n]`` takes the n-th match of the level; ``index`` (a one-item list, shared down
        the search) skips that many matches of the last segment."""
        Deadline.check()
        level = base.children if base is not None else self.top
        segment, _, rest = path.partition("/")
        pattern, nth, numbered = segment, 0, False
        if "[" in segment:
            numbered = True
            opening = segment.find("[")
            digits = segment[opening + 1:-1] if segment.endswith("]") else ""
            if digits.isdigit() and digits.isascii() and len(digits) <= MAX_INDEX_DIGITS:
                pattern, nth = segment[:opening], int(digits)
            else:
                return None  # CoppeliaSim's bad index matches no alias either
        if not pattern or any(c in "[]{}" for c in pattern):
            return None
        below: list[SceneObject] = []
        for obj in level:
            deeper = True
            if glob_match(pattern, obj.alias):
                deeper = not numbered
                if nth == 0:
                    if not rest:
                        if index[0] > 0:
                            index[0] -= 1
                        else:
                            return obj
                    else:
                        found = self._in_tree(obj, rest, index)
                        if found is not None:
                            return found
                if numbered:
                    nth -= 1
            if deeper:
                below.append(obj)
        for obj in below:
            found = self._in_tree(obj, path, index)
            if found is not None:
                return found
        return None

    def hint(self, path: str) -> str:
        """What a path that found nothing missed: the scene's object it most likely meant (the
        stand-in answers only the names of the scene it stands for, so that a script that
        passes here runs on CoppeliaSim with that scene), else the robots the scene has."""
        near = self.similar(path)
        if near is not None:
            return f"this scene's object is '{self.path(near, short=True)}'"
        robots = [self.path(o) for o in self.top if o.kind == "robot"]
        return (f"this scene has {len(robots)} robot{'s' if len(robots) != 1 else ''}: " + ", ".join(robots)
                if robots else "this scene has no robots")

    def similar(self, path: str) -> SceneObject | None:
        """The object a path that found nothing most likely meant: one whose alias is the path's
        last alias written another way (``visionSensor`` for ``Vision_sensor``), or close to it."""
        last = path.rstrip("/").rsplit("/", 1)[-1].split("[", 1)[0].split("{", 1)[0]
        if not last or any(c in "*?" for c in last):
            return None
        objects = list(self.objects.values())
        if any(o.alias == last for o in objects):
            return None  # the name is the scene's: the path around it is what missed
        key = last.lower().replace("_", "")
        same = [o for o in objects if o.alias.lower().replace("_", "") == key]
        if same:
            return same[0]
        close = difflib.get_close_matches(last, sorted({o.alias for o in objects}), n=1, cutoff=0.75)
        return next((o for o in objects if close and o.alias == close[0]), None)


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
