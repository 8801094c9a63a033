"""Chipmunk's C functions for the pymunk backend's hottest paths: sonar rays, wheel velocities, winches.

pymunk's Python layer costs more than the physics it wraps on these paths. A ray through
``Space.segment_query_first`` allocates a result struct, a ``SegmentQueryInfo`` and two
``Vec2d`` per call and looks the hit shape up, where a sonar only needs ``alpha``; a body's
``velocity_func`` goes through an ``ffi.from_handle``, a ``Vec2d`` for gravity and pymunk's
``__setattr__`` layer. Profiled on the wall lab (30,000 ticks, six rays a tick), those
wrappers were about half of the run. Here the same chipmunk calls are made directly,
through the ``ffi`` and ``lib`` pymunk itself is built with, with the same arguments, so the
readings and the poses are bit for bit those of pymunk's wrappers.

This leans on one module of pymunk's that is not its public API (``pymunk._chipmunk_cffi``):
chipmunk's own functions, which pymunk has exposed under that name since pymunk 6. A pymunk
without it fails the import here, at the backend's import, not in the middle of a run.
"""
from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import pymunk
from pymunk._chipmunk_cffi import ffi, lib

# The C functions a generated sense() and the wheel drive call, as module constants: a
# lookup on ``lib`` costs an attribute access per call.
segment_query_first = lib.cpSpaceSegmentQueryFirst
point_query_nearest = lib.cpSpacePointQueryNearest
body_position = lib.cpBodyGetPosition
body_angle = lib.cpBodyGetAngle
body_velocity = lib.cpBodyGetVelocity
set_velocity = lib.cpBodySetVelocity
set_angular_velocity = lib.cpBodySetAngularVelocity
space_step = lib.cpSpaceStep
# ... and those a mechanism's winch calls before every sub-step (labsim.backends.pymunk.joints)
local_to_world = lib.cpBodyLocalToWorld
velocity_at_world_point = lib.cpBodyGetVelocityAtWorldPoint
apply_force_at_world_point = lib.cpBodyApplyForceAtWorldPoint
set_position = lib.cpBodySetPosition
set_slide_max = lib.cpSlideJointSetMax
impulse = lib.cpConstraintGetImpulse


def query_info() -> Any:
    """A result struct for ``segment_query_first``, made once and reused by every ray."""
    return ffi.new("cpSegmentQueryInfo *")


def point_info() -> Any:
    """A result struct for ``point_query_nearest``, made once and reused by every query."""
    return ffi.new("cpPointQueryInfo *")


def shape_filter(f: pymunk.ShapeFilter) -> Any:
    """A ``pymunk.ShapeFilter`` as chipmunk's struct, converted once rather than on every ray."""
    return ffi.new("cpShapeFilter *", (f.group, f.categories, f.mask))[0]


def c_body(body: pymunk.Body) -> Any:
    """The ``cpBody *`` of a pymunk body (valid as long as the body lives)."""
    return body._body


def c_constraint(constraint: pymunk.Constraint) -> Any:
    """The ``cpConstraint *`` of a pymunk constraint (valid as long as it lives)."""
    return constraint._constraint


def c_space(space: pymunk.Space) -> Any:
    """The ``cpSpace *`` of a pymunk space (valid as long as the space lives)."""
    return space._space


class WheelDrives:
    """The bodies' wheel drive: each body's velocity is vs[robot] along its heading and ws[robot]
    as its turn, set anew after every step (``after_step``) for a free body and by a C velocity
    callback inside the step for a body in contact (``hold``).

    A body's velocity must be the command's inside a step, after contacts are found and before
    they are solved (see ``labsim.backends.pymunk.fleet``), so that the solver can take away what
    an obstacle blocks. For a body with no contact in a step nothing acts on its velocity after
    that point: chipmunk's own update leaves it as it is (no gravity, forces or damping here),
    and setting it after the step, from the heading the step gave, is bit for bit what the
    callback would have set. That spares a free body the C -> Python callback every step. A
    contact's ``begin`` handler, which runs before the step's velocity update, calls ``hold``
    for both bodies, so a body is under its callback in every step where it touches; it goes
    back to being set by hand after the first step that ends with it free.

    Where the platform refuses to make C callbacks at run time (``ffi.callback`` needs memory
    that is both writable and executable), every body goes through pymunk's ``velocity_func``
    at every step instead, as before.
    """

    def __init__(self, bodies: Sequence[pymunk.Body], vs: Sequence[float], ws: Sequence[float]) -> None:
        self._c = [c_body(b) for b in bodies]
        self._vs, self._ws = vs, ws
        cos, sin = math.cos, math.sin
        get_angle, set_v, set_w = body_angle, set_velocity, set_angular_velocity

        def drive(robot: int) -> Callable[[Any, object, float, float], None]:
            def velocity(cp_body: Any, _gravity: object, _damping: float, _dt: float) -> None:
                a = get_angle(cp_body)
                v = vs[robot]
                set_v(cp_body, (v * cos(a), v * sin(a)))
                set_w(cp_body, ws[robot])
            return velocity

        drives = [drive(r) for r in range(len(bodies))]
        try:
            self._callbacks: list[Any] = [ffi.callback("cpBodyVelocityFunc", d) for d in drives]
        except (MemoryError, RuntimeError):  # no executable memory for a callback: pymunk's route
            for body, d in zip(bodies, drives):
                body.velocity_func = _through_pymunk(d)
            self._callbacks = drives
            self._held = [True] * len(bodies)  # for good
            self._by_hand: list[int] = []
            self._own: Any = None
            return
        self._held = [False] * len(bodies)  # under the callback
        self._by_hand = list(range(len(bodies)))  # the others, set after each step (order is immaterial)
        self._own = ffi.addressof(lib, "cpBodyUpdateVelocity")  # chipmunk's own update

    def hold(self, robot: int) -> None:
        """Put the body under its callback (a contact of it has begun in this step)."""
        if not self._held[robot]:
            self._held[robot] = True
            lib.cpBodySetVelocityUpdateFunc(self._c[robot], self._callbacks[robot])
            self._by_hand.remove(robot)

    def after_step(self, touching: Sequence[int]) -> None:
        """After a step: release the held bodies that touch nothing now, and set the velocity
        of every free body from its command and its new heading."""
        if len(self._by_hand) < len(self._c) and self._own is not None:
            for robot, held in enumerate(self._held):
                if held and touching[robot] == 0:
                    self._held[robot] = False
                    lib.cpBodySetVelocityUpdateFunc(self._c[robot], self._own)
                    self._by_hand.append(robot)
        self._set(self._by_hand, self._c, self._vs, self._ws)

    def stepper(self, space: Any, h: float, substeps: int, touching: list[int],
                time_s: list[float]) -> Callable[[], None]:
        """A tick's physics as one closure: ``substeps`` chipmunk steps of ``h`` seconds of the
        ``cpSpace *`` ``space``, each followed by ``after_step`` (done inline while no body is
        held) and by each touching robot's ``h`` added to its ``time_s``. It runs every tick:
        the attribute loads and calls of ``after_step`` and ``_set`` cost as much as the wall
        lab's physics step. The lists it reads are the ones ``hold`` and ``after_step`` change
        in place."""
        by_hand, c, vs, ws, n, release = self._by_hand, self._c, self._vs, self._ws, len(self._c), self.after_step
        step, get_angle, set_v, set_w, cos, sin, any_ = space_step, body_angle, set_velocity, set_angular_velocity, \
            math.cos, math.sin, any

        def one() -> None:
            step(space, h)  # a touching body's velocity update applies its wheel commands
            if len(by_hand) < n:  # a body is held: after_step releases it once free
                release(touching)
            else:  # and a free body's are set now, as _set does
                for robot in by_hand:
                    body = c[robot]
                    a = get_angle(body)
                    v = vs[robot]
                    set_v(body, (v * cos(a), v * sin(a)))
                    set_w(body, ws[robot])
            if any_(touching):
                for r, t in enumerate(touching):
                    if t:
                        time_s[r] += h

        if n == 1:  # one robot, the labs' common case: no loops
            body0 = c[0]

            def one() -> None:
                step(space, h)
                if by_hand:  # free: its wheel commands along its new heading, as _set does
                    a = get_angle(body0)
                    v = vs[0]
                    set_v(body0, (v * cos(a), v * sin(a)))
                    set_w(body0, ws[0])
                else:  # held: after_step releases it once free
                    release(touching)
                if touching[0]:
                    time_s[0] += h

        if substeps == 1:
            return one
        ticks = range(substeps)

        def several() -> None:
            for _ in ticks:
                one()

        return several

    @staticmethod
    def _set(robots: list[int], c: list[Any], vs: Sequence[float], ws: Sequence[float],
             cos: Callable[[float], float] = math.cos, sin: Callable[[float], float] = math.sin,
             get_angle: Any = body_angle, set_v: Any = set_velocity, set_w: Any = set_angular_velocity) -> None:
        for robot in robots:  # the functions as default arguments: locals, not globals, in the loop
            body = c[robot]
            a = get_angle(body)
            v = vs[robot]
            set_v(body, (v * cos(a), v * sin(a)))
            set_w(body, ws[robot])


def _through_pymunk(drive: Callable[[Any, object, float, float], None]) -> Callable[..., None]:
    def velocity_func(body: pymunk.Body, gravity: object, damping: float, dt: float) -> None:
        drive(body._body, gravity, damping, dt)
    return velocity_func
