"""The stand-in's simulation: labsim's pymunk backend behind CoppeliaSim's scene.

Where it sits: ``labsim serve`` (``server``) keeps one ``Simulation``; the ``sim.*`` functions
(``sim_api``) read and drive it. It owns the scene tree (``scene_tree``), the robots' wheel
targets and odometry, the mechanism's joint targets, the simulation state and the clock, and
drives ``labsim.backends.pymunk.backend.PymunkBackend`` through the public backend protocol
(open / sense / act / command / step / pose / close) only. Poses become CoppeliaSim's 3D ones
through ``frames``.

Semantics kept from CoppeliaSim, and where the stand-in differs (docs/coppeliasim.md):

* ``start`` opens a fresh backend at the robots' scene poses; ``stop`` closes it, which puts
  the robots back where they were when it started, as CoppeliaSim restores a scene, and
  resets every client's stepping level, as CoppeliaSim's stopSimulation does.
* Wheel targets are applied at the next step, and only when they changed, so re-sending an
  unchanged target costs nothing and changes nothing. Joint targets likewise wait for the step.
* A wheel's angle follows from how the body moved (no slip), by odometry backwards.
* Without stepping, a running simulation advances on its own at about real time
  (``run_clock``); with stepping, each ``sim.step`` of a stepping client advances one step,
  and several stepping clients do not wait for each other.
* Readings are one ``sense()`` of the backend per step (``snapshot``), taken when first asked.
"""
from __future__ import annotations

import math
import random
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import cast

from labsim.backends.coppeliasim import PAUSED, RUNNING, STOPPED
from labsim.backends.coppeliasim.frames import Pose3, on_parent, slewed, wheel_turns, wrap
from labsim.backends.protocol import Backend, BackendError, RobotRequest
from labsim.backends.scene.mechanism import JointSpec
from labsim.backends.scene.models import PIONEER_P3DX, RobotModel
from labsim.backends.scene.world import Pose, World
from labsim.runtime.serve.scene_tree import ROBOT_Z_M, SceneObject, SceneTree

MAX_LAG_S = 0.25  # free-running behind real time by more than this: skip ahead, do not spiral


@dataclass(eq=False)
class Client:
    """A connected client, as the simulation sees it."""

    uuid: str
    lang: str
    timeout_s: float
    last_seen: float  # time.perf_counter() of its last request
    stepping: int = 0  # sim.setStepping level (cumulative, as CoppeliaSim's)
    step_pending: bool | None = None  # after sim.step: whether _*executed*_ advances


@dataclass(eq=False)
class Robot:
    """A Pioneer of the scene: where it starts, what the clients asked, what odometry says."""

    model: RobotModel
    pose: Pose  # where it starts: the scene's pose, changed by set* while stopped
    obj: SceneObject
    row: dict[str, int] = field(default_factory=dict)  # channel -> index in its sense() row
    target: list[float] = field(default_factory=lambda: [0.0, 0.0])  # rad/s asked by a client
    scene_target: list[float] = field(default_factory=lambda: [0.0, 0.0])  # rad/s set while stopped: the scene's
    target_pos: list[float] = field(default_factory=lambda: [0.0, 0.0])  # rad, kept and unused (velocity mode)
    acted: list[float] = field(default_factory=lambda: [0.0, 0.0])  # rad/s the backend has
    wheel: list[float] = field(default_factory=lambda: [0.0, 0.0])  # wheel angles, rad, from odometry
    wheel_rate: list[float] = field(default_factory=lambda: [0.0, 0.0])  # rad/s over the last step
    last: tuple[float, float, float] = (0.0, 0.0, 0.0)  # pose after the last step
    yaw_rate: float = 0.0  # rad/s over the last step


def robot_specs(world: World, robots: int | Sequence[RobotRequest]) -> list[tuple[RobotModel, Pose]]:
    """(model, start pose) of each robot: a count of Pioneers at the world's spawn poses
    (then at free random places, 1.2 m apart), or the models and poses of requests (their
    channels are not used: the server offers every channel of the model)."""
    if not isinstance(robots, int):
        return [(r.model, r.pose) for r in robots if r.model is not None]
    if robots < 0:
        raise BackendError(f"labsim serve: the number of robots must be 0 or more, not {robots}")
    out: list[tuple[RobotModel, Pose]] = []
    spawns = list(world.spawns)
    rng = random.Random(f"labsim serve/{world.name}")
    for i in range(robots):
        if i < len(spawns):
            pose = spawns[i]
        else:  # more robots than spawn poses: free places 0.6 m clear of walls, 1.2 m apart
            free = world.free_pose(rng, [p for _, p in out], 0.6)
            if free is None:
                raise BackendError(f"labsim serve: world '{world.name}' has no free place for robot {i + 1} "
                                   f"of {robots} (0.6 m clear of walls, 1.2 m from the others): ask for fewer")
            pose = free
        out.append((PIONEER_P3DX, pose))
    return out


class Simulation:
    """The scene and its simulation; ``dt_s`` is the time step, ``log`` takes progress lines."""

    def __init__(self, world: World, robots: int | Sequence[RobotRequest], dt_s: float,
                 log: Callable[[str], None], handles: dict[str, int] | None = None) -> None:
        self.world = world
        self.dt_s = dt_s
        self.log = log
        self.tree = SceneTree()
        specs = robot_specs(world, robots)
        if world.mechanism is not None and specs:
            raise BackendError(f"labsim serve: world '{world.name}' is a mechanism; it has no place for "
                               f"robots (serve it with --robots 0)")
        self.robots = [self._add_robot(i, model, pose) for i, (model, pose) in enumerate(specs)]
        self.mech: int | None = None  # the mechanism's index among the backend's robots
        self.mech_row: dict[str, int] = {}
        self.mech_targets: dict[str, tuple[str, float]] = {}  # joint -> (mode, value) asked
        self.mech_pending: dict[str, tuple[str, float]] = {}  # not yet given to the backend
        self.mech_scene: dict[str, tuple[str, float]] = {}  # set while stopped: the scene's, kept into a run
        self._add_mechanism(world, handles)

        self.clients: dict[str, Client] = {}
        self.state = STOPPED
        self.steps = 0
        self.next_due = 0.0  # perf_counter time of the next free-running step
        self._backend: Backend | None = None
        self._snap: list[list[object]] | None = None

    def _add_robot(self, i: int, model: RobotModel, pose: Pose) -> Robot:
        base = self.tree.add_robot(i, model)
        channels = [s.name for s in model.rays()] + ["x", "y", "heading", "collided"]
        if "forward_speed" in model.channels():
            channels.append("forward_speed")
        channels += [c.name for c in model.cameras]
        channels += [b.name for b in model.bumpers] + [g.name for g in model.ground_sensors]
        robot = Robot(model, pose, base, {ch: n for n, ch in enumerate(channels)})
        robot.last = (pose.x_m, pose.y_m, wrap(pose.heading_rad))
        return robot

    def _add_mechanism(self, world: World, handles: dict[str, int] | None) -> None:
        """Joints, force sensors and moving bodies of the world's mechanism, if it has one
        (``handles``: those its parts were built with, by name)."""
        m = world.mechanism
        if m is None:
            return
        channels = self.tree.add_mechanism(m, handles)
        self.mech = len(self.robots)
        self.mech_row = {ch: n for n, ch in enumerate(channels)}

    @property
    def running(self) -> bool:
        """Whether a backend is open (the simulation is running or paused)."""
        return self._backend is not None

    @property
    def time_s(self) -> float:
        return self.steps * self.dt_s

    # --- state -------------------------------------------------------------------------------

    def stepping(self) -> bool:
        """Whether some client steps the simulation (else it runs on its own when running)."""
        return any(c.stepping > 0 for c in self.clients.values())

    def start(self) -> None:
        """sim.startSimulation: from stopped, a fresh scene; from paused, go on."""
        if self.state == STOPPED:
            self._open()
        elif self.state == PAUSED:
            self.state = RUNNING
            self.next_due = time.perf_counter() + self.dt_s

    def _open(self) -> None:
        from labsim.backends.pymunk.backend import PymunkBackend

        backend = PymunkBackend()
        requests = [RobotRequest(f"PioneerP3DX[{i}]", r.model, r.pose, tuple(r.row))
                    for i, r in enumerate(self.robots)]
        if self.mech is not None:
            requests.append(RobotRequest(self.world.name, None, Pose(0.0, 0.0, 0.0), tuple(self.mech_row)))
        backend.open(self.world, requests, self.dt_s, 0)
        self._backend = backend
        self.state = RUNNING
        self.steps = 0
        self._snap = None
        self.next_due = time.perf_counter() + self.dt_s
        for r in self.robots:
            # a target set while stopped is the scene's value, kept into the run (as CoppeliaSim does)
            r.target, r.acted = list(r.scene_target), [0.0, 0.0]
            r.wheel, r.wheel_rate, r.yaw_rate = [0.0, 0.0], [0.0, 0.0], 0.0
            r.last = (r.pose.x_m, r.pose.y_m, wrap(r.pose.heading_rad))
        self.mech_targets = dict(self.mech_scene)
        self.mech_pending = dict(self.mech_scene)
        self.log(f"labsim serve: simulation started (dt {self.dt_s:g} s)")

    def stop(self) -> None:
        """sim.stopSimulation: close the backend; the robots are back at their scene poses."""
        if self._backend is not None:
            self._backend.close()
            self.log(f"labsim serve: simulation stopped at t = {self.steps * self.dt_s:.2f} s "
                     f"({self.steps} steps)")
        self._backend = None
        self.state = STOPPED
        self.steps = 0
        self._snap = None
        for c in self.clients.values():
            c.stepping = 0  # CoppeliaSim's stopSimulation resets every client's stepping level
        for r in self.robots:  # the scene's values come back, as CoppeliaSim restores a scene
            r.target, r.wheel, r.wheel_rate, r.yaw_rate = list(r.scene_target), [0.0, 0.0], [0.0, 0.0], 0.0
        self.mech_targets = dict(self.mech_scene)
        self.mech_pending.clear()

    def pause(self) -> None:
        if self.state == RUNNING:
            self.state = PAUSED

    # --- time --------------------------------------------------------------------------------

    def client_step(self, client: Client) -> None:
        """The step a client's sim.step asked for, once it said _*executed*_."""
        if self.state != RUNNING:
            return
        self.advance()
        if client.stepping == 0:
            # A free-running client asked to wait for the next step: it has happened now, so
            # the real-time clock restarts from here rather than stepping twice.
            self.next_due = time.perf_counter() + self.dt_s

    def run_clock(self, now: float) -> None:
        """Free-running: advance to real time (``now``, perf_counter seconds)."""
        if now - self.next_due > MAX_LAG_S:
            self.next_due = now  # too far behind (a slow machine): catch up from now
        while now >= self.next_due:
            self.advance()
            self.next_due += self.dt_s

    def advance(self) -> None:
        """One step: wheel targets that changed, joint targets, physics, odometry."""
        backend = self._backend
        assert backend is not None
        for i, r in enumerate(self.robots):
            if r.target != r.acted:
                # the model's wheel limit, as a behaviour's commands meet it (runtime/run.py): one
                # algorithm moves alike as a script and as a behaviour (docs/coppeliasim.md)
                top = r.model.max_wheel_speed_rad_s
                backend.act(i, *(max(-top, min(top, v)) for v in r.target))
                r.acted = list(r.target)
        if self.mech is not None and self.mech_pending:
            for joint, (mode, value) in self.mech_pending.items():
                backend.command(self.mech, joint, mode, value)
            self.mech_pending.clear()
        backend.step()
        self.steps += 1
        self._snap = None
        dt = self.dt_s
        for i, r in enumerate(self.robots):
            # The wheels' angles follow from how the body moved (no slip): what a student
            # doing odometry from sim.getJointPosition expects, also when a wall stops it.
            now = backend.pose(i)
            left, right, da = wheel_turns(r.last, now, r.model.axle_length_m, r.model.wheel_radius_m)
            for side, turn in ((0, left), (1, right)):
                r.wheel[side] += turn
                r.wheel_rate[side] = turn / dt
            r.yaw_rate = da / dt
            r.last = now

    # --- readings ----------------------------------------------------------------------------

    def snapshot(self) -> list[list[object]]:
        """Every channel of every robot and of the mechanism, as the last step left them."""
        if self._snap is None:
            assert self._backend is not None
            self._snap = self._backend.sense()
        return self._snap

    def sensed(self, obj: SceneObject) -> object | None:
        """What the last step saw for a robot's sensor (its channel ``obj.name``), or None
        before the first step: CoppeliaSim handles sensors at the end of a step."""
        if self._backend is None or self.steps == 0:
            return None
        return self.snapshot()[obj.robot][self.robots[obj.robot].row[obj.name]]

    def detected_point(self, obj: SceneObject, distance_m: float) -> list[float]:
        """Where a proximity sensor detected something ``distance_m`` away, in its own frame as
        the stock Pioneer's sensors have it (z along the axis, x to its left, y up): along the
        ray of a sonar's cone that found it; along the axis where the backend cannot tell
        which, or the state has changed since the step's reading (a noisy reading, a robot
        moved while stopped), and for a bumper."""
        hit = getattr(self._backend, "sonar_hit", None) if obj.kind == "sonar" else None
        found = hit(obj.robot, obj.name) if hit is not None else None
        a = float(found[1]) if found is not None and found[0] == distance_m else 0.0
        return [distance_m * math.sin(a), 0.0, distance_m * math.cos(a)]

    def part(self, name: str) -> Sequence[float]:
        """A mechanism channel's value now: (position, velocity), (tension,) or (x, z, angle)."""
        assert self.mech is not None
        return cast("Sequence[float]", self.snapshot()[self.mech][self.mech_row[name]])

    def joint_spec(self, obj: SceneObject) -> JointSpec:
        assert self.world.mechanism is not None
        return self.world.mechanism.joint(obj.name)

    def joint_state(self, obj: SceneObject) -> tuple[float, float]:
        """A mechanism joint's (position, velocity): its start position while stopped."""
        if self._backend is None:
            assert self.world.mechanism is not None
            return (self.world.mechanism.initial_position(self.joint_spec(obj)), 0.0)
        value = self.part(obj.name)
        return (float(value[0]), float(value[1]))

    # --- poses -------------------------------------------------------------------------------

    def robot_pose(self, i: int) -> tuple[float, float, float]:
        """x, y, heading of robot ``i``: the backend's, or the scene's while stopped."""
        if self._backend is not None:
            return self._backend.pose(i)
        p = self.robots[i].pose
        return (p.x_m, p.y_m, wrap(p.heading_rad))

    def world_pose(self, obj: SceneObject) -> Pose3:
        """x, y, z, yaw of an object in the world."""
        if obj.kind == "robot":
            x, y, a = self.robot_pose(obj.robot)
            return (x, y, ROBOT_Z_M, a)
        if obj.kind in ("joint", "force", "body"):
            x, y, z, slew, _ = self.mechanism_frame(obj)
            return (x, y, z, wrap(slew))
        assert obj.parent is not None
        return on_parent(self.world_pose(obj.parent), obj.mount)

    def mechanism_frame(self, obj: SceneObject) -> tuple[float, float, float, float, float]:
        """X, Y, Z of a mechanism part in 3D, the slew angle and its angle in the plane.

        A body's place in the vertical plane (x along, z up) turned by the slew angle about the
        slew axis (labsim.backends.scene.mechanism); a joint is where its child body is, a force
        sensor where its second body is."""
        m = self.world.mechanism
        assert m is not None
        name = obj.name
        if obj.kind == "joint":
            name = self.joint_spec(obj).child
        elif obj.kind == "force":
            name = next(s.between[1] for s in m.force_sensors if s.name == obj.name)
        if self._backend is not None and name in self.mech_row:
            x, z, theta = self.part(name)
        else:
            body = m.body(name)
            (x, z), theta = body.center, body.angle_rad
        slew = m.slew
        angle = 0.0
        if slew is not None and slew.name in self.mech_row:
            angle = self.joint_state(self.tree.named(slew.name))[0]
        if angle == 0.0:
            return (float(x), 0.0, float(z), 0.0, float(theta))
        assert slew is not None
        sx, sy, sz = slewed(float(x), float(z), angle, slew.anchor[0])
        return (sx, sy, sz, angle, float(theta))
