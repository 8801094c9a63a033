"""The backend contract as a function anyone can run: ``check_backend(make_backend)``.

Where it sits: beside ``labsim.backends.protocol``, which says what a backend must do. This
module sets a short scene, has ``check_drive.Drive`` drive three backends through it the way
the runtime does (sense, act or command, step, tick after tick), compares what they read, and
says, one plain sentence per problem, where a backend does otherwise, as Gymnasium's
``check_env`` does for environments. labsim's contract test calls it on every registered
backend and on a scripted fake; the author of a new backend calls it on theirs (docs/api.md).
Like every backend it imports no test framework and nothing of the language or the runtime.
"""
from __future__ import annotations

import math
from collections.abc import Callable, Sequence

from labsim.backends.check_drive import Drive, Scene, Tick, check_shut, show
from labsim.backends.protocol import Backend, RobotRequest
from labsim.backends.scene.models import PIONEER_P3DX, POSE_CHANNELS, Camera, Kind, Sonar
from labsim.backends.scene.world import Pose, Wall, World, builtin_worlds, world_channels
from labsim.backends.scene.world_file import load_world
from labsim.foundation.diagnostics import Report

# The scene checked when none is given: two Pioneers in a 6 m box, reading every channel the
# model offers. Robot a starts 0.55 m from the east wall, so the drive bumps it into the wall
# twice and its contacts are checked against its collided readings.
BOX = World("box", "a 6 m box", (-3, -3, 3, 3), walls=(
    Wall((-3, -3), (3, -3), 0.1), Wall((3, -3), (3, 3), 0.1), Wall((3, 3), (-3, 3), 0.1), Wall((-3, 3), (-3, -3), 0.1)))
BOX_ROBOTS = (RobotRequest("a", PIONEER_P3DX, Pose(2.2, 0.0, 0.0), tuple(PIONEER_P3DX.channels())),
              RobotRequest("b", PIONEER_P3DX, Pose(-1.5, 1.5, math.pi / 2), tuple(PIONEER_P3DX.channels())))

MAX_LISTED = 20  # problems the error's message lists; all are in its ``failures``


class BackendContractError(AssertionError):
    """A backend does otherwise than the protocol says. ``failures`` holds one sentence per
    problem (each said once, at the first tick it showed); the message lists them."""

    def __init__(self, backend: str, failures: Sequence[str]) -> None:
        self.backend = backend
        self.failures = tuple(failures)
        lines = [f"  - {f}" for f in self.failures[:MAX_LISTED]]
        if len(self.failures) > MAX_LISTED:
            lines.append(f"  ... and {len(self.failures) - MAX_LISTED} more")
        super().__init__(f"backend '{backend}' does not keep the backend contract (labsim.backends.protocol); "
                         f"{len(self.failures)} problem(s):\n" + "\n".join(lines))


def check_backend(make_backend: Callable[[], Backend], world: World | str | None = None,
                  robots: Sequence[RobotRequest] | None = None, *, dt_s: float = 0.05, ticks: int = 100,
                  seed: int = 7) -> None:
    """Check that the backends ``make_backend()`` returns keep the backend contract.

    ``make_backend`` is called three times, for three fresh backends: the first is checked
    call by call (calls before ``open`` and after ``close`` raise ``BackendStateError``;
    ``sense`` returns one list per robot holding its requested channels, each of its
    documented type and unit; ``pose`` agrees with ``x``, ``y``, ``heading``; ``contacts``
    follow ``collided``; a command the scene cannot carry out raises ``BackendError``), the
    second must read exactly the same (same world, requests, dt, seed and commands: the same
    readings), and the third, asked for every robot's channels in reverse order, must read
    them reversed. Joints are commanded only in a world with a mechanism, and camera images
    are checked only when a request asks for a camera.

    ``world``: the scene to drive, a ``World`` or the name of a built-in world (``"crane"``);
    None for two Pioneers in a box (``BOX``, ``BOX_ROBOTS``). ``robots``: what to ask of it;
    for a world with a mechanism it may be left out (the mechanism, every channel read).
    Raises ``BackendContractError`` listing every problem found, or ``ValueError`` when the
    scene asked for does not fit (a channel the model does not offer).

    Example, for the author of a backend::

        from labsim.backends import check_backend
        from my_simulator import MyBackend

        check_backend(MyBackend)           # two robots in a box, 100 ticks of 0.05 s
        check_backend(MyBackend, "crane")  # if it simulates mechanisms too
    """
    scene = _scene(world, robots, dt_s, ticks, seed)
    findings: dict[str, str] = {}  # a problem's kind -> its first sentence
    first = make_backend()
    name = getattr(first, "name", None)
    if not isinstance(name, str) or not name:
        findings["name"] = (f"the backend's name is {name!r}; a backend names itself in the attribute `name`, "
                            "a non-empty str (traces and messages show it)")
    check_shut(first, "before open()", findings)
    checked = Drive(first, scene, findings, checked=True).history()
    again = Drive(make_backend(), scene, findings).history()
    flipped = Drive(make_backend(), scene.reversed(), findings).history()
    if checked is not None and again is not None:
        same = _first_difference(scene, checked, again, flip=False)
        if same is not None:
            findings["seeded"] = (
                f"two backends given the same world, requests, dt_s, seed ({seed}) and commands read differently: "
                f"{same}; readings may depend on nothing else (randomness only from the seed given to open())")
        elif flipped is not None:
            order = _first_difference(scene, checked, flipped, flip=True)
            if order is not None:
                findings["order"] = (
                    f"asked for every robot's channels in reverse order, the backend read them otherwise: {order}; "
                    "sense() must return each robot's channels in the order its request lists them")
    if findings:
        raise BackendContractError(name if isinstance(name, str) and name else type(first).__name__,
                                   list(findings.values()))


# --- the scene ---------------------------------------------------------------------------------

def _scene(world: World | str | None, robots: Sequence[RobotRequest] | None, dt_s: float, ticks: int,
           seed: int) -> Scene:
    """The scene to drive, its requests checked against what the world and models offer."""
    if not (isinstance(dt_s, (int, float)) and dt_s > 0 and math.isfinite(dt_s)):
        raise ValueError(f"check_backend: dt_s must be a positive number of seconds, not {dt_s!r}")
    if not isinstance(ticks, int) or ticks < 1:
        raise ValueError(f"check_backend: ticks must be a positive integer, not {ticks!r}")
    if world is None:
        if robots is not None:
            raise ValueError("check_backend: robots= needs the world= they are in")
        world, robots = BOX, BOX_ROBOTS
    elif isinstance(world, str):
        world = _builtin(world)
    if robots is None:
        if world.mechanism is None:
            raise ValueError(f"check_backend: world '{world.name}' has no mechanism; say which robots to "
                             "put in it with robots=[RobotRequest(...), ...]")
        robots = (RobotRequest(world.name, None, Pose(0.0, 0.0, 0.0), tuple(_offered(world, None))),)
    requests = tuple(robots)
    if not requests:
        raise ValueError("check_backend: robots= is empty; a scene needs at least one robot to read")
    kinds, specs = [], []
    for req in requests:
        offered = _offered(world, req)
        unknown = [c for c in req.channels if c not in offered]
        if unknown:
            raise ValueError(f"check_backend: robot '{req.name}' asks for channel(s) {', '.join(unknown)}, "
                             f"which it does not offer in world '{world.name}' (it offers: {', '.join(offered)})")
        kinds.append({c: offered[c] for c in req.channels})
        model_specs: list[Sonar | Camera] = [*req.model.rays(), *req.model.cameras] if req.model else []
        specs.append({s.name: s for s in model_specs})
    return Scene(world, requests, tuple(kinds), tuple(specs), float(dt_s), seed, ticks)


def _offered(world: World, req: RobotRequest | None) -> dict[str, Kind]:
    """The channels a robot (or, for a request without a model, the world's mechanism) offers."""
    if req is not None and req.model is not None:
        return {**req.model.channels(), **world_channels(world)}
    if world.mechanism is None:
        name = req.name if req is not None else world.name
        raise ValueError(f"check_backend: robot '{name}' has no model, which stands for the world's "
                         f"mechanism, and world '{world.name}' has none")
    return {**world.mechanism.channels(), **POSE_CHANNELS, "collided": Kind.BOOL}


def _builtin(name: str) -> World:
    worlds = builtin_worlds()
    if name not in worlds:
        raise ValueError(f"check_backend: no built-in world '{name}' (known: {', '.join(worlds)})")
    world = load_world(worlds[name], Report())
    if world is None:  # a shipped file that does not load is labsim's own bug
        raise ValueError(f"check_backend: the built-in world '{name}' does not load")
    return world


# --- two runs compared -------------------------------------------------------------------------

def _first_difference(scene: Scene, a: list[Tick], b: list[Tick], flip: bool) -> str | None:
    """Where two runs of the scene first differ, said for a person (``flip``: b read every robot's
    channels in reverse order); None when they agree."""
    first, then = ("in the given order", "in reverse order") if flip else ("in one", "in the other")
    for t, (x, y) in enumerate(zip(a, b)):
        for i, req in enumerate(scene.requests):
            row = y.readings[i][::-1] if flip else y.readings[i]
            for channel, u, v in zip(req.channels, x.readings[i], row):
                if u != v:
                    said = f"{show(u)} {first} and {show(v)} {then}"
                    return f"robot '{req.name}' channel '{channel}' read {said} at tick {t}"
            calls = ((f"pose({i})", x.poses[i], y.poses[i]), (f"contacts({i})", x.contacts[i], y.contacts[i]))
            for call, u, v in calls:
                if u != v:
                    return f"{call} returned {show(u)} {first} and {show(v)} {then} at tick {t}"
    return None
