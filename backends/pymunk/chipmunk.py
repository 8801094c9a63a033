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


def wheel_drive(body: pymunk.Body, vs: Sequence[float], ws: Sequence[float], robot: int) -> Any:
    """Make body's velocity update impose vs[robot] along its heading and ws[robot] as its turn.

    The update runs inside the step, after contacts are found and before they are solved (see
    ``labsim.backends.pymunk.fleet``). It is installed as a C callback of chipmunk's own, so a
    step calls it without going through pymunk's ``velocity_func`` machinery. Where the
    platform refuses to make C callbacks at run time (``ffi.callback`` needs memory that is
    both writable and executable), the same function goes through ``velocity_func`` instead.
    Returns what must stay referenced as long as the body is stepped.
    """
    cos, sin = math.cos, math.sin
    get_angle, set_v, set_w = body_angle, set_velocity, set_angular_velocity

    def drive(cp_body: Any, _gravity: object, _damping: float, _dt: float) -> None:
        a = get_angle(cp_body)
        v = vs[robot]
        set_v(cp_body, (v * cos(a), v * sin(a)))
        set_w(cp_body, ws[robot])

    try:
        callback = ffi.callback("cpBodyVelocityFunc", drive)
    except (MemoryError, RuntimeError):  # no executable memory for a callback: pymunk's route
        body.velocity_func = _through_pymunk(drive)
        return drive
    lib.cpBodySetVelocityUpdateFunc(body._body, callback)
    return callback


def _through_pymunk(drive: Callable[[Any, object, float, float], None]) -> Callable[..., None]:
    def velocity_func(body: pymunk.Body, gravity: object, damping: float, dt: float) -> None:
        drive(body._body, gravity, damping, dt)
    return velocity_func
