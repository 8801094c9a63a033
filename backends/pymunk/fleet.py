"""A fleet of rovers in a room, seen from above: the pymunk backend's simulator for robot worlds.

``labsim.backends.pymunk.backend.PymunkBackend`` opens a ``FleetSimulator`` for every world
without a mechanism. It builds a top-down pymunk scene from the ``World`` (walls as static
segments, blocks as static polygons) and one dynamic body per robot, drives each body as a
differential-drive robot without lateral slip, reads sonars as ray casts (a fan of rays for a
sonar's cone), and counts contacts through collision callbacks. It is deterministic: the same world, robots, commands
and dt give bit-identical readings in every run and process.

Beyond sonars, pose and ``collided``, a robot may read:

* a camera (a name from ``RobotModel.cameras``): an RGB image of the world's ground from
  ``labsim.backends.pymunk.camera``, with the walls, blocks and other robots standing on it
  drawn by ``labsim.backends.pymunk.scene_view``; OpenCV is imported, and the ground drawn,
  only when some robot reads a camera;
* a lidar's beams (``lidar1`` ..), from the model's ``Lidar``: the whole fan cast at once
  (``labsim.backends.pymunk.lidar_fan``), reading what single rays would;
* a bumper (``RobotModel.bumpers``): True while a wall, block or robot comes within its reach
  of its point on the chassis (one chipmunk point query);
* a ground sensor (``RobotModel.ground_sensors``): the reflectance 0..1 of the ground's texture
  under its point (``labsim.backends.pymunk.camera``, which draws the ground once);
* ``forward_speed``: m/s, the body's velocity along its heading, as the last step moved it;
* in a world with a road (``labsim.backends.scene.ground.world_channels``): ``road_offset``,
  ``on_road`` and ``laps``, measured at the robot's origin against the first road. Laps are
  counted in ``step()``, once per tick after the physics (not per sub-step), for the robots
  that read them, so they do not depend on how often ``sense()`` is called.

``sense()`` is generated for the channels read (``labsim.backends.pymunk.fleet_sense``):
nothing is computed for a channel no robot reads.
"""
from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import Any

import pymunk

from labsim.backends.protocol import BackendError, ContactStats, RobotRequest
from labsim.backends.pymunk import chipmunk
from labsim.backends.pymunk.fleet_sense import (
    BumperRead,
    CameraRead,
    GroundRead,
    LidarBeam,
    SensePlan,
    SonarRay,
    Spec,
    compile_sense,
    cone_hit,
)
from labsim.backends.pymunk.simulator import COLLISION_SLOP_M
from labsim.backends.scene.ground import ROAD_CHANNELS, Ground, RoadTracker
from labsim.backends.scene.models import RobotModel, Sonar
from labsim.backends.scene.world import Block, World, first_road, world_channels, wrap

# Shared by robots, walls and blocks; pymunk multiplies the two shapes' values. Robots slide
# along walls rather than sticking to them, yet a glancing contact still turns them a little.
FRICTION = 0.5
# A bumping robot must not bounce: the real one stops against the obstacle.
ELASTICITY = 0.0

# Collision type of walls and blocks; robot i gets i + 1, so a callback maps a shape to its
# robot without a lookup table.
_STATIC_TYPE = 0


class FleetSimulator:
    """Robots on a floor among walls and blocks; built open by the constructor.

    ``space`` is the ``pymunk.Space``; ``bodies`` the robots' bodies, in the order of the
    requests. A body's position is the robot-frame origin (the middle of the wheel axle), its
    angle the heading, and its velocity update applies the wheel commands last given to
    ``act`` (see ``PymunkBackend`` for driving the scene by hand).
    """

    def __init__(self, world: World, robots: Sequence[RobotRequest], dt_s: float, substeps: int) -> None:
        """Check every request, then build the scene; raises BackendError, leaving nothing built."""
        models = _check(world, robots)
        space = pymunk.Space()
        space.gravity = (0.0, 0.0)  # top-down: gravity points into the floor
        space.collision_slop = COLLISION_SLOP_M
        # Insertion order fixes pymunk's internal order, hence determinism: walls, blocks,
        # then robots, each in the order given.
        self._blocks = _add_obstacles(space, world)  # block number -> its shape (a live view moves them)
        n = len(robots)
        vs = [0.0] * n  # commanded forward speed per robot, m/s (act() writes them)
        ws = [0.0] * n  # commanded turn rate per robot, rad/s
        plans = [_add_robot(space, i, req, model) for i, (req, model) in enumerate(zip(robots, models))]
        # A touching body's velocity update imposes its wheel commands inside the step, after
        # contacts are found and before they are solved, so the solver can still take away
        # the part of the motion an obstacle blocks, and the next step moves the body with
        # what is left. Setting the velocity before step() instead would overwrite that
        # corrected velocity, and a robot driving into a wall would sink into it by about
        # v * dt every step. A free body's is set after each step, to the same numbers
        # (chipmunk.WheelDrives says why). The callbacks must live as long as the space.
        self._drives = chipmunk.WheelDrives([plan.body for plan in plans], vs, ws)
        touching = [0] * n  # contacts in progress, per robot
        count = [0] * n
        _count_contacts(space, touching, count, self._drives.hold)
        self._scene = _camera_scene(world, models, robots, [plan.body for plan in plans])
        render = self._scene.render if self._scene is not None else None
        poses = self._scene.poses if self._scene is not None else None
        tracker = _road_tracker(world)
        lap_robots = [i for i, req in enumerate(robots) if "laps" in req.channels]
        laps = [0] * n  # completed laps, for the robots that read them
        if tracker is not None:
            for i in lap_robots:
                tracker.start(i, robots[i].pose.x_m, robots[i].pose.y_m)

        self.space = space
        self.bodies = [plan.body for plan in plans]
        self._plans = plans
        self._channels = [list(req.channels) for req in robots]
        self.sense = compile_sense(space, plans, touching, render, tracker, laps, _reflectance(world, models, robots),
                                   poses)
        self._c_space = chipmunk.c_space(space)
        self._c_bodies = [chipmunk.c_body(b) for b in self.bodies]
        self._world = world.name
        self._world_blocks = world.blocks
        self._substep_s = dt_s / substeps
        self._substep_range = range(substeps)
        # Laps: the first road's tracker and the robots that read laps (a world without a
        # road has no robot that reads them: _check refuses the channel).
        self._tracker = tracker
        self._lap_robots = lap_robots
        self._laps = laps
        self._half_r = [m.wheel_radius_m / 2.0 for m in models]  # R / 2: wheel speed sum to m/s
        self._r_over_axle = [m.wheel_radius_m / m.axle_length_m for m in models]  # to rad/s
        self._v = vs
        self._w = ws
        self._touching = touching
        self._count = count
        self._time_s = [0.0] * n  # simulated time spent touching something
        self.step = self._stepper()

    def act(self, robot: int, left_rad_s: float, right_rad_s: float) -> None:
        v = self._half_r[robot] * (left_rad_s + right_rad_s)
        w = self._r_over_axle[robot] * (right_rad_s - left_rad_s)
        self._v[robot] = v
        self._w[robot] = w
        # pymunk moves a body with the velocity it has when step() begins and only then calls
        # the velocity_func, so a new command would show one step late. A free robot takes it
        # at once; a touching one waits a step rather than lose its contact-corrected velocity
        # (overwriting that would push it into the obstacle by up to v * dt).
        if self._touching[robot] == 0:
            body = self._c_bodies[robot]
            a = chipmunk.body_angle(body)
            chipmunk.set_velocity(body, (v * math.cos(a), v * math.sin(a)))
            chipmunk.set_angular_velocity(body, w)

    def command(self, robot: int, joint: str, mode: str, value: float) -> None:
        raise BackendError(f"pymunk backend: world '{self._world}' has no mechanism, so no joint "
                           f"'{joint}' to command")

    def _stepper(self) -> Callable[[], None]:
        """``step()``: the tick's physics (``chipmunk.WheelDrives.stepper``: chipmunk's step
        itself, as pymunk's Space.step adds the handling of shapes added or removed from
        callbacks and the fleet's callbacks only count contacts), then the laps. A closure over
        what it reads, built once: it runs every tick."""
        physics = self._drives.stepper(self._c_space, self._substep_s, len(self._substep_range), self._touching,
                                       self._time_s)
        if not self._lap_robots:
            return physics
        tracker, laps, bodies, lap_robots = self._tracker, self._laps, self.bodies, self._lap_robots
        assert tracker is not None  # laps are refused in a world without a road

        def step() -> None:
            physics()
            for r in lap_robots:  # once per tick, after the physics: see the module docstring
                x, y = bodies[r].position
                laps[r] = tracker.update(r, x, y)

        return step

    def place(self, robot: int, x_m: float, y_m: float, heading_rad: float) -> str | None:
        """Put a robot at a pose, at rest (a hand moving it: a live view's drag); None when
        done, or why not: it would overlap a wall, a block or another robot (nothing moves)."""
        body = self.bodies[robot]
        before = (body.position, body.angle)
        body.position, body.angle = (x_m, y_m), heading_rad
        self.space.reindex_shapes_for_body(body)
        shape = next(iter(body.shapes))
        hits = [h for h in self.space.shape_query(shape) if h.shape is not None and h.shape.body is not body]
        if hits:
            body.position, body.angle = before
            self.space.reindex_shapes_for_body(body)
            what = "another robot" if any(h.shape.body is not self.space.static_body for h in hits) \
                else "a wall or a block"
            return f"it would overlap {what} there"
        body.velocity, body.angular_velocity = (0.0, 0.0), 0.0
        return None

    def set_block(self, block: int, corners: Sequence[tuple[float, float]] | None) -> str | None:
        """Move block ``block`` to these corners, add it (a new number) or remove it (None): a hand
        changing the room (a live view's drag). None when done, or why not: it would overlap a wall
        or a robot (blocks may overlap blocks). Cameras see the change from the next frame."""
        old = self._blocks.get(block)
        new = None
        if corners is not None:
            new = _block_shape(self.space.static_body, corners)
            new.cache_bb()
            hits = [h.shape for h in self.space.shape_query(new) if h.shape is not None]
            if any(h.body is not self.space.static_body for h in hits):
                return "it would overlap a robot there"
            blocks = set(self._blocks.values())
            if any(h not in blocks for h in hits):
                return "it would overlap a wall there"
        if old is not None:
            self.space.remove(old)
            del self._blocks[block]
        if new is not None:
            self.space.add(new)
            self._blocks[block] = new
        if self._scene is not None:
            from labsim.backends.pymunk.scene_view import block_solid
            self._scene.set_block(block, None if corners is None else block_solid(self._solid_of(block, corners)))
        return None

    def _solid_of(self, block: int, corners: Sequence[tuple[float, float]]) -> Block:
        """The block as cameras see it: a world's block keeps its height and colour."""
        given = self._world_blocks[block] if block < len(self._world_blocks) else Block(())
        return replace(given, corners=tuple(corners))

    def pose(self, robot: int) -> tuple[float, float, float]:
        body = self.bodies[robot]
        x, y = body.position
        return (x, y, wrap(body.angle))

    def contacts(self, robot: int) -> ContactStats:
        return ContactStats(self._count[robot], self._time_s[robot])

    def sonar_hit(self, robot: int, channel: str) -> tuple[float, float] | None:
        """Where a sonar the robot reads detects something now: (distance m, the direction of
        the ray that found it, radians counter-clockwise from the sonar's axis), or None. The
        distance is the one ``sense()`` reads in this state (``fleet_sense.cone_hit``)."""
        plan = self._plans[robot]
        spec = plan.specs[self._channels[robot].index(channel)]
        assert isinstance(spec, SonarRay)
        found = cone_hit(self.space, plan, spec)
        if found is None:
            return None
        dx, dy = spec.ends()[found[1]]
        return found[0], math.atan2(dy, dx) - math.atan2(spec.end_dy_m, spec.end_dx_m)


def _check(world: World, robots: Sequence[RobotRequest]) -> list[RobotModel]:
    """Every request's model, once each channel and sonar is known to work; else BackendError."""
    from_world = world_channels(world)
    models = []
    for req in robots:
        model = req.model
        if model is None:
            raise BackendError(f"robot '{req.name}' has no model, and world '{world.name}' has no "
                               f"mechanism for it to drive")
        offered = model.channels()
        cameras = {c.name: c for c in model.cameras}
        for ch in req.channels:
            if ch in ROAD_CHANNELS and ch not in from_world and ch not in offered:
                raise BackendError(
                    f"robot '{req.name}' asks for '{ch}', but world '{world.name}' has no "
                    f"road; '{ch}' needs a world whose ground has roads"
                )
            if ch not in offered and ch not in from_world:
                raise BackendError(
                    f"robot '{req.name}' asks for unknown channel '{ch}'; model "
                    f"'{model.name}' offers: {', '.join([*offered, *from_world])}"
                )
            if ch in cameras:
                from labsim.backends.pymunk.camera import check_camera  # OpenCV: only now
                try:
                    check_camera(cameras[ch])
                except ValueError as e:
                    raise BackendError(f"robot '{req.name}', model '{model.name}': {e}") from None
        for s in model.rays():
            # A ray needs finite ends (and sense() writes these numbers as literals).
            if not all(math.isfinite(v) for v in (s.x_m, s.y_m, s.angle_rad, s.range_m)) or s.range_m <= 0:
                raise BackendError(
                    f"model '{model.name}': sonar '{s.name}' needs a finite mount and "
                    f"angle and a positive finite range (got {s})"
                )
        models.append(model)
    return models


def _camera_scene(world: World, models: list[RobotModel], robots: Sequence[RobotRequest],
                  bodies: list[pymunk.Body]) -> Any:
    """The ``SceneView`` of the world's ground, walls, blocks and these robots' bodies, or
    None when no robot reads a camera (then OpenCV is not imported and the ground not drawn)."""
    if not any(c.name in req.channels for model, req in zip(models, robots) for c in model.cameras):
        return None
    try:
        from labsim.backends.pymunk.camera import ground_view
        from labsim.backends.pymunk.scene_view import scene_view
        ground = ground_view(world.ground if world.ground is not None else Ground())
        return scene_view(ground, world, list(zip(bodies, models)))
    except ValueError as e:
        raise BackendError(f"world '{world.name}': {e}") from None


def _reflectance(world: World, models: list[RobotModel],
                 robots: Sequence[RobotRequest]) -> Callable[[float, float], float] | None:
    """``GroundView.reflectance`` for the world's ground, or None when no robot reads a ground
    sensor (then OpenCV is not imported and the ground not drawn)."""
    if not any(g.name in req.channels for model, req in zip(models, robots) for g in model.ground_sensors):
        return None
    try:
        from labsim.backends.pymunk.camera import ground_view
        return ground_view(world.ground if world.ground is not None else Ground()).reflectance
    except ValueError as e:
        raise BackendError(f"world '{world.name}': {e}") from None


def _road_tracker(world: World) -> RoadTracker | None:
    """The tracker of the world's first road, which the road channels measure against."""
    road = first_road(world)
    try:
        return RoadTracker(road) if road is not None else None
    except ValueError as e:  # only a Ground built in code can get here: files are checked
        raise BackendError(f"world '{world.name}': {e}") from None


def _add_obstacles(space: pymunk.Space, world: World) -> dict[int, pymunk.Poly]:
    """The world's walls, then its blocks, as static shapes in file order; the blocks' shapes."""
    static = space.static_body
    for wall in world.walls:
        seg = pymunk.Segment(static, wall.a, wall.b, wall.thickness_m / 2.0)
        seg.friction, seg.elasticity, seg.collision_type = FRICTION, ELASTICITY, _STATIC_TYPE
        space.add(seg)
    blocks = {}
    for k, block in enumerate(world.blocks):
        blocks[k] = _block_shape(static, block.corners)
        space.add(blocks[k])
    return blocks


def _block_shape(static: pymunk.Body, corners: Sequence[tuple[float, float]]) -> pymunk.Poly:
    poly = pymunk.Poly(static, corners)
    poly.friction, poly.elasticity, poly.collision_type = FRICTION, ELASTICITY, _STATIC_TYPE
    return poly


def _add_robot(space: pymunk.Space, i: int, req: RobotRequest, model: RobotModel) -> SensePlan:
    """Robot i's body and shape; what its sense() reads."""
    moment = pymunk.moment_for_poly(model.mass_kg, model.footprint)
    body = pymunk.Body(model.mass_kg, moment)
    body.position = (req.pose.x_m, req.pose.y_m)
    body.angle = req.pose.heading_rad
    shape = pymunk.Poly(body, model.footprint)
    shape.friction, shape.elasticity = FRICTION, ELASTICITY
    shape.collision_type = i + 1
    # Group i + 1: the robot's own rays skip its own shape (they start on or inside it) but
    # still hit walls, blocks (group 0) and every other robot.
    shape.filter = pymunk.ShapeFilter(group=i + 1)
    space.add(body, shape)

    sonars = {s.name: s for s in model.sonars}
    beams = {f"lidar{k + 1}": (lidar, a) for lidar in model.lidars for k, a in enumerate(lidar.angles_rad())}
    cameras = {c.name: c for c in model.cameras}
    bumpers = {b.name: b for b in model.bumpers}
    ground = {g.name: g for g in model.ground_sensors}
    specs: list[Spec] = []
    for ch in req.channels:
        s = sonars.get(ch)
        if s is not None:
            specs.append(sonar_spec(s))
        elif ch in beams:
            lidar, angle = beams[ch]
            specs.append(LidarBeam(lidar.x_m, lidar.range_m, angle))
        elif ch in cameras:
            specs.append(CameraRead(cameras[ch]))
        elif ch in bumpers:
            specs.append(BumperRead(bumpers[ch].x_m, bumpers[ch].y_m, bumpers[ch].reach_m))
        elif ch in ground:
            specs.append(GroundRead(ground[ch].x_m, ground[ch].y_m))
        else:
            specs.append(ch)  # pose, collided, forward_speed, road: checked in _check
    return SensePlan(body, pymunk.ShapeFilter(group=i + 1), tuple(specs))


def sonar_spec(s: Sonar) -> SonarRay:
    """A model's sonar as the ray, or the fan of rays, ``sense()`` casts (robot frame)."""
    fan = tuple((s.range_m * math.cos(a), s.range_m * math.sin(a)) for a in s.ray_angles_rad()) \
        if s.cone_deg > 0.0 else ()
    limit = math.radians(s.incidence_limit_deg)
    return SonarRay(s.x_m, s.y_m, s.range_m * math.cos(s.angle_rad), s.range_m * math.sin(s.angle_rad),
                    s.range_m, fan, math.cos(limit) if fan and s.incidence_limit_deg < 90.0 else None)


def _count_contacts(space: pymunk.Space, touching: list[int], count: list[int],
                    hold: Callable[[int], None]) -> None:
    """Keep touching[r] (contacts in progress) and count[r] (contacts begun) for each robot,
    and ``hold(r)`` each robot a contact of which begins (its wheel drive then goes through
    the step's velocity update).

    A contact is counted when a robot goes from touching nothing to touching something, so
    pressing against a wall for many ticks, or sliding along it into a corner, is one contact.
    Both shapes of a robot-robot contact are robots, so both count.
    """
    def begin(arbiter: pymunk.Arbiter, _space: pymunk.Space, _data: object) -> None:
        for shape in arbiter.shapes:
            r = shape.collision_type - 1
            if r >= 0:
                if touching[r] == 0:
                    count[r] += 1
                    hold(r)
                touching[r] += 1

    def separate(arbiter: pymunk.Arbiter, _space: pymunk.Space, _data: object) -> None:
        for shape in arbiter.shapes:
            r = shape.collision_type - 1
            if r >= 0 and touching[r] > 0:
                touching[r] -= 1

    space.on_collision(None, None, begin=begin, separate=separate)
