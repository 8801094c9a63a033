"""The embedded 2D simulator, and labsim's default backend.

It builds a top-down pymunk scene from a ``World`` (walls as static segments, blocks as
static polygons) and one dynamic body per robot, drives each body as a differential-drive
robot without lateral slip, reads sonars as single ray casts, and counts contacts through
collision callbacks. It needs nothing but pymunk, runs in-process, and is deterministic: the
same world, robots, commands and dt give bit-identical readings in every run and process.
The runtime reaches it only through ``labsim.backends.protocol.Backend``; ``space`` and
``bodies`` are public so that a benchmark can drive the very same scene by hand.

Beyond sonars, pose and ``collided``, a robot may read:

* a camera (a name from ``RobotModel.cameras``): an RGB image of the world's ground from
  ``labsim.backends.pymunk.camera`` (walls and robots are not in it); OpenCV is imported, and
  the ground drawn, only when some robot reads a camera;
* ``forward_speed``: m/s, the body's velocity along its heading, as the last step moved it;
* in a world with a road (``labsim.backends.scene.ground.world_channels``): ``road_offset``,
  ``on_road`` and ``laps``, measured at the robot's origin against the first road. Laps are
  counted in ``step()``, once per tick after the physics (not per sub-step), for the robots
  that read them, so they do not depend on how often ``sense()`` is called.

Nothing is computed for a channel no robot reads: sense() for a sonar-only behaviour is the
same code as before these channels existed.
"""
from __future__ import annotations

import math
from typing import Callable, Sequence

import pymunk

from labsim.backends.scene.ground import ROAD_CHANNELS, Ground, RoadTracker, first_road, world_channels
from labsim.backends.protocol import BackendError, BackendStateError, ContactStats, RobotRequest
from labsim.backends.scene.world import World

# Shared by robots, walls and blocks; pymunk multiplies the two shapes' values. Robots slide
# along walls rather than sticking to them, yet a glancing contact still turns them a little.
FRICTION = 0.5
# A bumping robot must not bounce: the real one stops against the obstacle.
ELASTICITY = 0.0
# Allowed overlap between shapes, metres. pymunk's default (0.1) assumes pixels; in metres it
# would let a robot sink 10 cm into a wall, so the sonars and the pose would be off.
COLLISION_SLOP_M = 0.0005

# Collision type of walls and blocks; robot i gets i + 1, so a callback maps a shape to its
# robot without a lookup table.
_STATIC_TYPE = 0

_SONAR = "sonar"  # tags a sonar's channel spec in _compile_sense
_CAMERA = "camera"  # tags a camera's channel spec (a camera's own name could be anything)

_TWO_PI = 2.0 * math.pi


def _wheel_drive(
    vs: list[float], ws: list[float], robot: int,
) -> Callable[[pymunk.Body, object, float, float], None]:
    """A body velocity_func that imposes robot's commanded speed along its heading.

    pymunk calls it inside step(), after contacts are found and before they are solved, so
    the solver can still take away the part of the motion an obstacle blocks, and the next
    step moves the body with what is left. Setting the velocity before step() instead would
    overwrite that corrected velocity, and a robot driving into a wall would sink into it by
    about v * dt every step.
    """
    cos, sin = math.cos, math.sin

    def drive(body: pymunk.Body, _gravity: object, _damping: float, _dt: float) -> None:
        a = body.angle
        v = vs[robot]
        body.velocity = (v * cos(a), v * sin(a))
        body.angular_velocity = ws[robot]

    return drive


def _wrap(angle: float) -> float:
    """The same angle in (-pi, pi]."""
    a = math.remainder(angle, _TWO_PI)
    return math.pi if a == -math.pi else a


def _compile_sense(
    query: Callable[..., pymunk.SegmentQueryInfo | None],
    robots: list[tuple[pymunk.Body, pymunk.ShapeFilter, list[tuple]]],
    touching: list[int],
    render: Callable[..., object] | None = None,
    tracker: RoadTracker | None = None,
    laps: list[int] | None = None,
) -> Callable[[], list[list[object]]]:
    """Generate ``sense()`` as straight-line code for these robots and channels.

    sense() runs every tick, and its cost beyond the ray casts themselves must stay near
    zero. Unrolled code with the sonar geometry as literals skips the per-sonar loop and
    tuple unpacking, which makes it measurably cheaper than a hand-written loop over the
    same rays. For one robot asking for sonar1 and collided it reads (numbers rounded)::

        def sense():
            x0, y0 = body0.position
            a0 = body0.angle
            c = cos(a0)
            s = sin(a0)
            ox = x0 + c * 0.1067 - s * 0.1382
            oy = y0 + s * 0.1067 + c * 0.1382
            hit = query((ox, oy), (ox + c * 0.0 - s * 1.0, oy + s * 0.0 + c * 1.0), 0.0, filter0)
            v0_0 = inf if hit is None else hit.alpha * 1.0
            return [[v0_0, touching[0] > 0]]

    ``robots`` holds per robot its body, its rays' shape filter, and its channels in the
    requested order: ``(_SONAR, mount_x, mount_y, end_dx, end_dy, range)``,
    ``(_CAMERA, camera)`` or ``(name,)``. repr() of a float reads back as the same float, so
    the literals change no reading. Cameras call ``render(x, y, angle, camera)``; road
    channels call ``tracker.offset`` once per robot; ``laps`` reads the list ``step()`` keeps.
    """
    env: dict[str, object] = {
        "query": query, "cos": math.cos, "sin": math.sin, "inf": math.inf, "wrap": _wrap,
        "touching": touching, "abs": abs, "render": render, "laps": laps,
        "offset": tracker.offset if tracker is not None else None,
    }
    half_width = tracker.half_width_m if tracker is not None else 0.0
    lines = ["def sense():"]
    rows = []
    for r, (body, flt, specs) in enumerate(robots):
        env[f"body{r}"] = body
        env[f"filter{r}"] = flt
        kinds = {spec[0] for spec in specs}
        if kinds & {_SONAR, "x", "y", _CAMERA, "road_offset", "on_road"}:
            lines.append(f"    x{r}, y{r} = body{r}.position")
        if kinds & {_SONAR, "heading", _CAMERA, "forward_speed"}:
            lines.append(f"    a{r} = body{r}.angle")
        if _SONAR in kinds:
            lines += [f"    c = cos(a{r})", f"    s = sin(a{r})"]
        if kinds & {"road_offset", "on_road"}:
            lines.append(f"    ro{r} = offset(x{r}, y{r})")  # once, for both channels
        values = []
        for k, spec in enumerate(specs):
            if spec[0] == _CAMERA:
                env[f"cam{r}_{k}"] = spec[1]
                lines.append(f"    v{r}_{k} = render(x{r}, y{r}, a{r}, cam{r}_{k})")
                values.append(f"v{r}_{k}")
            elif spec[0] == "forward_speed":
                lines += [
                    f"    vx, vy = body{r}.velocity",
                    f"    v{r}_{k} = vx * cos(a{r}) + vy * sin(a{r})",
                ]
                values.append(f"v{r}_{k}")
            elif spec[0] == _SONAR:
                _, mx, my, ex, ey, rng = spec
                lines += [
                    f"    ox = x{r} + c * {mx!r} - s * {my!r}",
                    f"    oy = y{r} + s * {mx!r} + c * {my!r}",
                    f"    hit = query((ox, oy), (ox + c * {ex!r} - s * {ey!r}, "
                    f"oy + s * {ex!r} + c * {ey!r}), 0.0, filter{r})",
                    f"    v{r}_{k} = inf if hit is None else hit.alpha * {rng!r}",
                ]
                values.append(f"v{r}_{k}")
            else:
                values.append({
                    "x": f"x{r}", "y": f"y{r}", "heading": f"wrap(a{r})",
                    "collided": f"touching[{r}] > 0",
                    "road_offset": f"ro{r}", "on_road": f"abs(ro{r}) <= {half_width!r}",
                    "laps": f"laps[{r}]",
                }[spec[0]])
        rows.append(f"[{', '.join(values)}]")
    lines.append(f"    return [{', '.join(rows)}]")
    exec(compile("\n".join(lines), "<labsim pymunk sense>", "exec"), env)
    return env["sense"]  # type: ignore[return-value]


class PymunkBackend:
    """The ``Backend`` protocol on a pymunk ``Space``.

    Public attributes, valid between ``open`` and ``close`` (``None`` and ``[]`` otherwise):

    * ``space``: the ``pymunk.Space`` holding the scene.
    * ``bodies``: the robots' ``pymunk.Body`` objects, in the order of ``open``'s ``robots``.
      A body's position is the robot-frame origin (the middle of the wheel axle), its angle
      the heading. Each body's ``velocity_func`` applies the wheel commands last given to
      ``act``, so code driving the scene by hand should call ``act`` and ``space.step``, or
      replace ``velocity_func``; a velocity set directly lasts only until the next step.
    """

    name = "pymunk"

    def __init__(self, substeps: int = 1) -> None:
        """``substeps``: physics steps per ``step()``, each dt_s / substeps long.

        The wheel commands are re-applied in every sub-step, so more sub-steps give steadier
        contacts and a finer arc when turning, at a proportional cost; sense() is unaffected.
        """
        if not isinstance(substeps, int) or isinstance(substeps, bool) or substeps < 1:
            raise BackendError(
                f"pymunk backend: substeps must be a positive integer, not {substeps!r}"
            )
        self.substeps = substeps
        self._substep_range = range(substeps)
        self.space: pymunk.Space | None = None
        self.bodies: list[pymunk.Body] = []
        self._substep_s = 0.0
        self._sense: Callable[[], list[list[object]]] | None = None  # see _compile_sense
        self._half_r: list[float] = []  # R / 2, turns wheel speed sum into m/s
        self._r_over_axle: list[float] = []  # R / axle, turns wheel speed difference into rad/s
        self._v: list[float] = []  # commanded forward speed, m/s
        self._w: list[float] = []  # commanded turn rate, rad/s
        # Contacts: kept after close() so a summary can still read them.
        self._touching: list[int] = []  # contacts in progress, per robot
        self._count: list[int] = []
        self._time_s: list[float] = []
        # Laps: the first road's tracker, the robots that read laps, their completed laps.
        self._tracker: RoadTracker | None = None
        self._lap_robots: list[int] = []
        self._laps: list[int] = []
        self._opened = False
        self._scene = None  # a mechanism world's MechanismScene (then there are no robots)
        self._tracked: str | None = None

    # --- protocol ---------------------------------------------------------------------------

    def open(self, world: World, robots: Sequence[RobotRequest], dt_s: float, seed: int) -> None:
        """Build the scene. ``seed`` is unused: nothing in this backend is random."""
        if self.space is not None:
            raise BackendStateError("pymunk backend: open() called twice; close() it first")
        if not dt_s > 0:
            raise BackendError(f"pymunk backend: dt_s must be positive, not {dt_s!r}")
        if world.mechanism is not None:
            self._open_mechanism(world, robots, dt_s)
            return
        # Check every channel before building anything, so a bad request leaves no half scene.
        from_world = world_channels(world)
        if world.ground is not None and not isinstance(world.ground, Ground):
            raise BackendError(f"world '{world.name}': its ground is not a labsim Ground "
                               f"({type(world.ground).__name__})")
        cameras_read = False
        for req in robots:
            offered = req.model.channels()
            cameras = {c.name: c for c in req.model.cameras}
            for ch in req.channels:
                if ch in ROAD_CHANNELS and ch not in from_world and ch not in offered:
                    raise BackendError(
                        f"robot '{req.name}' asks for '{ch}', but world '{world.name}' has no "
                        f"road; '{ch}' needs a world whose ground has roads"
                    )
                if ch not in offered and ch not in from_world:
                    raise BackendError(
                        f"robot '{req.name}' asks for unknown channel '{ch}'; model "
                        f"'{req.model.name}' offers: {', '.join([*offered, *from_world])}"
                    )
                if ch in cameras:
                    cameras_read = True
                    from labsim.backends.pymunk.camera import check_camera  # OpenCV: only now
                    try:
                        check_camera(cameras[ch])
                    except ValueError as e:
                        raise BackendError(f"robot '{req.name}', model '{req.model.name}': {e}") from None
            for s in req.model.sonars:
                # A ray needs finite ends (and sense() writes these numbers as literals).
                if not all(math.isfinite(v) for v in (s.x_m, s.y_m, s.angle_rad, s.range_m)) \
                        or s.range_m <= 0:
                    raise BackendError(
                        f"model '{req.model.name}': sonar '{s.name}' needs a finite mount and "
                        f"angle and a positive finite range (got {s})"
                    )

        space = pymunk.Space()
        space.gravity = (0.0, 0.0)  # top-down: gravity points into the floor
        space.collision_slop = COLLISION_SLOP_M

        # Insertion order fixes pymunk's internal order, hence determinism: walls, blocks,
        # then robots, each in the order given.
        static = space.static_body
        for wall in world.walls:
            seg = pymunk.Segment(static, wall.a, wall.b, wall.thickness_m / 2.0)
            seg.friction, seg.elasticity, seg.collision_type = FRICTION, ELASTICITY, _STATIC_TYPE
            space.add(seg)
        for block in world.blocks:
            poly = pymunk.Poly(static, block.corners)
            poly.friction, poly.elasticity, poly.collision_type = FRICTION, ELASTICITY, _STATIC_TYPE
            space.add(poly)

        n = len(robots)
        vs = [0.0] * n  # commanded forward speed per robot, m/s (act() writes them)
        ws = [0.0] * n  # commanded turn rate per robot, rad/s
        bodies: list[pymunk.Body] = []
        plans: list[tuple] = []
        for i, req in enumerate(robots):
            model = req.model
            moment = pymunk.moment_for_poly(model.mass_kg, model.footprint)
            body = pymunk.Body(model.mass_kg, moment)
            body.position = (req.pose.x_m, req.pose.y_m)
            body.angle = req.pose.heading_rad
            shape = pymunk.Poly(body, model.footprint)
            shape.friction, shape.elasticity = FRICTION, ELASTICITY
            shape.collision_type = i + 1
            # Group i + 1: the robot's own rays skip its own shape (they start on or inside
            # it) but still hit walls, blocks (group 0) and every other robot.
            shape.filter = pymunk.ShapeFilter(group=i + 1)
            body.velocity_func = _wheel_drive(vs, ws, i)
            space.add(body, shape)
            bodies.append(body)

            sonars_by_name = {s.name: s for s in model.sonars}
            cameras_by_name = {c.name: c for c in model.cameras}
            specs: list[tuple] = []
            for ch in req.channels:
                s = sonars_by_name.get(ch)
                if ch in cameras_by_name and s is None:
                    specs.append((_CAMERA, cameras_by_name[ch]))
                elif s is None:
                    specs.append((ch,))  # pose, collided, forward_speed, road: checked above
                else:
                    # The ray's end offset from the mount in the robot frame is the whole
                    # range along the axis, so the hit's alpha times range is the distance.
                    specs.append((
                        _SONAR, s.x_m, s.y_m,
                        s.range_m * math.cos(s.angle_rad), s.range_m * math.sin(s.angle_rad),
                        s.range_m,
                    ))
            plans.append((body, pymunk.ShapeFilter(group=i + 1), specs))

        touching = [0] * n
        count = [0] * n

        # A contact is counted when a robot goes from touching nothing to touching something,
        # so pressing against a wall for many ticks, or sliding along it into a corner, is one
        # contact. Both shapes of a robot-robot contact are robots, so both count.
        def begin(arbiter: pymunk.Arbiter, _space: pymunk.Space, _data: object) -> None:
            for shape in arbiter.shapes:
                r = shape.collision_type - 1
                if r >= 0:
                    if touching[r] == 0:
                        count[r] += 1
                    touching[r] += 1

        def separate(arbiter: pymunk.Arbiter, _space: pymunk.Space, _data: object) -> None:
            for shape in arbiter.shapes:
                r = shape.collision_type - 1
                if r >= 0 and touching[r] > 0:
                    touching[r] -= 1

        space.on_collision(None, None, begin=begin, separate=separate)

        # Cameras and roads: built only when some robot reads them.
        render = None
        if cameras_read:
            try:
                from labsim.backends.pymunk.camera import ground_view
                render = ground_view(world.ground if world.ground is not None else Ground()).render
            except ValueError as e:
                raise BackendError(f"world '{world.name}': {e}") from None
        road = first_road(world)
        try:
            tracker = RoadTracker(road) if road is not None else None
        except ValueError as e:  # only a Ground built in code can get here: files are checked
            raise BackendError(f"world '{world.name}': {e}") from None
        lap_robots = [i for i, req in enumerate(robots) if "laps" in req.channels]
        laps = [0] * n
        if tracker is not None:
            for i in lap_robots:
                tracker.start(i, robots[i].pose.x_m, robots[i].pose.y_m)

        self.space = space
        self.bodies = bodies
        self._substep_s = dt_s / self.substeps
        self._sense = _compile_sense(space.segment_query_first, plans, touching, render, tracker, laps)
        self._tracker = tracker
        self._lap_robots = lap_robots
        self._laps = laps
        self._half_r = [req.model.wheel_radius_m / 2.0 for req in robots]
        self._r_over_axle = [req.model.wheel_radius_m / req.model.axle_length_m for req in robots]
        self._v = vs
        self._w = ws
        self._touching = touching
        self._count = count
        self._time_s = [0.0] * n
        self._opened = True

    def _open_mechanism(self, world: World, robots: Sequence[RobotRequest], dt_s: float) -> None:
        """A side view with gravity: the world's mechanism, read and driven by one agent.

        Channels: a joint reads (position, velocity), a force sensor (tension N,), a moving
        body (x, z, angle) in the plane; x, y are the last moving body's (x, z) and heading the
        slew angle, so that a trace follows the load; collided is always False.
        """
        from labsim.backends.pymunk.mechanism import MechanismError, MechanismScene

        mechanism = world.mechanism
        if any(req.model is not None for req in robots):
            raise BackendError(f"world '{world.name}' is a mechanism: it has no place for robots")
        try:
            scene = MechanismScene(mechanism, dt_s)  # type: ignore[arg-type]
        except MechanismError as e:
            raise BackendError(f"world '{world.name}': {e}") from None
        joints = {j.name for j in mechanism.joints if j.kind != "fixed"}  # type: ignore[union-attr]
        sensors = {f.name for f in mechanism.force_sensors}  # type: ignore[union-attr]
        moving = [b.name for b in mechanism.bodies if not b.static]  # type: ignore[union-attr]
        tracked = moving[-1] if moving else None

        def getter(name: str, ch: str) -> Callable[[], object]:
            if ch in joints:
                return lambda: (scene.joint_position(ch), scene.joint_velocity(ch))
            if ch in sensors:
                return lambda: (scene.force(ch),)
            if ch in moving:
                return lambda: scene.body_pose(ch)
            if tracked is not None and ch in ("x", "y"):
                index = 0 if ch == "x" else 1
                return lambda: scene.body_pose(tracked)[index]
            if ch == "heading":
                return lambda: scene.slew_angle
            if ch == "collided":
                return lambda: False
            raise BackendError(f"'{name}' asks for unknown channel '{ch}'; world '{world.name}' offers: "
                               + ", ".join(sorted(joints | sensors | set(moving))))

        getters = [[getter(req.name, ch) for ch in req.channels] for req in robots]
        self._sense = lambda: [[g() for g in row] for row in getters]
        self._scene = scene
        self._tracked = tracked
        self.space = scene.space
        self.bodies = []
        n = len(robots)
        self._touching, self._count, self._time_s = [0] * n, [0] * n, [0.0] * n
        self._lap_robots = []
        self._opened = True

    def command(self, robot: int, joint: str, mode: str, value: float) -> None:
        """A mechanism joint's target velocity or position (see the protocol)."""
        from labsim.backends.pymunk.mechanism import MechanismError

        scene = getattr(self, "_scene", None)
        if scene is None:
            raise self._state_error("command")
        try:
            if mode == "velocity":
                scene.set_target_velocity(joint, value)
            else:
                scene.set_target_position(joint, value)
        except MechanismError as e:
            raise BackendError(str(e)) from None

    def sense(self) -> list[list[object]]:
        fn = self._sense
        if fn is None:
            raise self._state_error("sense")
        return fn()

    def act(self, robot: int, left_rad_s: float, right_rad_s: float) -> None:
        if self._sense is None:
            raise self._state_error("act")
        v = self._half_r[robot] * (left_rad_s + right_rad_s)
        w = self._r_over_axle[robot] * (right_rad_s - left_rad_s)
        self._v[robot] = v
        self._w[robot] = w
        # pymunk moves a body with the velocity it has when step() begins and only then calls
        # the velocity_func, so a new command would show one step late. A free robot takes it
        # at once; a touching one waits a step rather than lose its contact-corrected velocity
        # (overwriting that would push it into the obstacle by up to v * dt).
        if self._touching[robot] == 0:
            body = self.bodies[robot]
            a = body.angle
            body.velocity = (v * math.cos(a), v * math.sin(a))
            body.angular_velocity = w

    def step(self) -> None:
        space = self.space
        if space is None:
            raise self._state_error("step")
        if self._scene is not None:
            self._scene.step()
            return
        touching, h = self._touching, self._substep_s
        for _ in self._substep_range:
            space.step(h)  # each body's velocity_func applies its wheel commands
            if any(touching):
                time_s = self._time_s
                for r, t in enumerate(touching):
                    if t:
                        time_s[r] += h
        if self._lap_robots:  # once per tick, after the physics: see the module docstring
            tracker, laps, bodies = self._tracker, self._laps, self.bodies
            for r in self._lap_robots:
                x, y = bodies[r].position
                laps[r] = tracker.update(r, x, y)

    def pose(self, robot: int) -> tuple[float, float, float]:
        if self._sense is None:
            raise self._state_error("pose")
        if self._scene is not None:
            x, z, _ = self._scene.body_pose(self._tracked) if self._tracked else (0.0, 0.0, 0.0)
            return (x, z, _wrap(self._scene.slew_angle))
        body = self.bodies[robot]
        x, y = body.position
        return (x, y, _wrap(body.angle))

    def contacts(self, robot: int) -> ContactStats:
        """Contacts so far; still readable after ``close`` (for the run's summary)."""
        if not self._opened:
            raise BackendStateError("pymunk backend: contacts() called before open()")
        return ContactStats(self._count[robot], self._time_s[robot])

    def close(self) -> None:
        if self.space is None:
            return
        # Freeing the space may fire separate callbacks; they only touch the lists above.
        self.space = None
        self.bodies = []
        self._sense = None
        self._scene = None
        self._tracker = None
        self._lap_robots = []

    # --- helpers ----------------------------------------------------------------------------

    def _state_error(self, call: str) -> BackendStateError:
        when = "after close()" if self._opened else "before open()"
        return BackendStateError(f"pymunk backend: {call}() called {when}; open() a world first")
