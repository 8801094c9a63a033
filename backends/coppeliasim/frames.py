"""3D frames and odometry: labsim's flat poses as CoppeliaSim's 3D ones, and back.

Where it sits: pure arithmetic, shared by both halves of the package and importing neither
a simulator nor the wire. The stand-in server (``simulation``, ``sim_api``) turns the pymunk
backend's poses into what CoppeliaSim would report: a robot's yaw-only pose on a flat floor,
a sensor's pose through its mount, a mechanism's body in its vertical plane turned by the
slew, wheel angles from the body's motion. The client backend (``fleet``, ``mechanism``)
turns CoppeliaSim's Euler angles back into labsim's heading and plane poses.

CoppeliaSim's Euler angles (alpha, beta, gamma) rotate about x, then the new y, then the new
z; its quaternions are (x, y, z, w). A mechanism's plane is labsim's (x along, z up), the
vertical plane y = 0 until the slew turns it about the vertical axis x = axis_x, y = 0.
Several functions have an exact branch for the common case (no tilt, no slew): the values
then cross the wire and come back bit for bit, which keeps traces identical.
"""
from __future__ import annotations

import math
from collections.abc import Sequence

from labsim.backends.scene.world import wrap as wrap  # the one angle wrap; the stand-in imports it from here

Pose3 = tuple[float, float, float, float]  # x, y, z (m), yaw (rad): the scene is flat


# --- the stand-in: labsim -> CoppeliaSim --------------------------------------------------------

def on_parent(parent: Pose3, mount: Pose3) -> Pose3:
    """The world pose of an object mounted at ``mount`` (x, y, z, yaw in the parent's frame)."""
    px, py, pz, pa = parent
    mx, my, mz, ma = mount
    c, s = math.cos(pa), math.sin(pa)
    return (px + c * mx - s * my, py + s * mx + c * my, pz + mz, wrap(pa + ma))


def seen_from(pose: Pose3, ref: Pose3) -> Pose3:
    """A world pose expressed in the frame of another object's world pose ``ref``."""
    x, y, z, a = pose
    rx, ry, rz, ra = ref
    c, s = math.cos(ra), math.sin(ra)
    dx, dy = x - rx, y - ry
    return (c * dx + s * dy, -s * dx + c * dy, z - rz, wrap(a - ra))


def yaw_quaternion(a: float) -> list[float]:
    """CoppeliaSim's quaternion (x, y, z, w) of a turn by ``a`` about z."""
    return [0.0, 0.0, math.sin(a / 2), math.cos(a / 2)]


def quaternion_yaw(qz: float, qw: float) -> float:
    """The turn about z of a quaternion with x = y = 0."""
    return wrap(2.0 * math.atan2(qz, qw))


def slewed(x: float, z: float, slew: float, axis_x: float) -> tuple[float, float, float]:
    """X, Y, Z in 3D of the plane point (x, z) once the plane has turned by ``slew``."""
    if slew == 0.0:
        return (x, 0.0, z)
    r = x - axis_x
    return (axis_x + r * math.cos(slew), r * math.sin(slew), z)


def plane_rotation(slew: float, theta: float) -> tuple[list[float], list[float]]:
    """CoppeliaSim's Euler angles and quaternion (x, y, z, w) of Rz(slew) Ry(-theta): a body
    tilted by theta in its vertical plane (counter-clockwise from x toward z), turned by
    the slew about the vertical."""
    if slew == 0.0 and abs(theta) <= math.pi / 2:
        # Ry(-theta) alone: beta is exactly -theta, which the backend reads back exactly
        c2, st2 = math.cos(theta / 2), math.sin(theta / 2)
        return [0.0, -theta, 0.0], [0.0, -st2, 0.0, c2]
    cs, ss, ct, st = math.cos(slew), math.sin(slew), math.cos(theta), math.sin(theta)
    # R = Rx(alpha) Ry(beta) Rz(gamma) with R = [[cs ct, -ss, -cs st], [ss ct, cs, -ss st], [st, 0, ct]]
    euler = [math.atan2(ss * st, ct), math.asin(max(-1.0, min(1.0, -cs * st))), math.atan2(ss, cs * ct)]
    c2, s2, ct2, st2 = math.cos(slew / 2), math.sin(slew / 2), math.cos(theta / 2), math.sin(theta / 2)
    return euler, [s2 * st2, -c2 * st2, s2 * ct2, c2 * ct2]


def wheel_turns(last: tuple[float, float, float], now: tuple[float, float, float],
                axle_length_m: float, wheel_radius_m: float) -> tuple[float, float, float]:
    """Odometry backwards: (left, right) wheel turns in rad, and the turn of the body in rad,
    that take a differential-drive robot from pose ``last`` to ``now`` (x, y, heading) without
    slip, moving along the arc's mean heading."""
    x0, y0, a0 = last
    x, y, a = now
    da = wrap(a - a0)
    mid = a0 + da / 2
    d = (x - x0) * math.cos(mid) + (y - y0) * math.sin(mid)
    half = axle_length_m / 2
    return ((d - da * half) / wheel_radius_m, (d + da * half) / wheel_radius_m, da)


# --- the backend: CoppeliaSim -> labsim ---------------------------------------------------------

def yaw(euler: Sequence[float]) -> float:
    """Heading (yaw of the robot's x axis, radians) from CoppeliaSim's Euler angles.

    On a flat floor alpha = beta = 0 and gamma is the heading, returned as it is (no
    rounding); otherwise the heading is that of the x axis projected onto the floor.
    """
    alpha, beta, gamma = euler[0], euler[1], euler[2]
    if alpha == 0.0 and beta == 0.0:
        return float(gamma)
    ca, sa, cb, sb = math.cos(alpha), math.sin(alpha), math.cos(beta), math.sin(beta)
    cg, sg = math.cos(gamma), math.sin(gamma)
    return math.atan2(ca * sg + sa * sb * cg, cb * cg)


def plane_pose(position: Sequence[float], euler: Sequence[float], slew: float,
               axis_x: float) -> tuple[float, float, float]:
    """(x, z, angle) in a mechanism's vertical plane of a body at 3D ``position`` with Euler
    angles ``euler``, the plane being turned by ``slew`` about the axis x = ``axis_x``."""
    x, y, z = position[0], position[1], position[2]
    alpha, beta, gamma = euler[0], euler[1], euler[2]
    if slew == 0.0 and alpha == 0.0 and gamma == 0.0:
        return (x, z, -beta)  # only tilted in the plane (about -y): exact, no trigonometry
    ca, sa, cb, sb = math.cos(alpha), math.sin(alpha), math.cos(beta), math.sin(beta)
    cg, sg = math.cos(gamma), math.sin(gamma)
    r00, r10, r20 = cb * cg, ca * sg + sa * sb * cg, sa * sg - ca * sb * cg  # the body's x axis
    if slew == 0.0:
        return (x, z, math.atan2(r20, r00))
    cs, ss = math.cos(slew), math.sin(slew)
    # turn back by the slew about the vertical axis x = axis_x, y = 0
    back = axis_x + (x - axis_x) * cs + y * ss
    return (_unslewed(back, x, y, slew, axis_x), z, math.atan2(r20, cs * r00 + ss * r10))


def _unslewed(guess: float, x: float, y: float, slew: float, axis_x: float, ulps: int = 16) -> float:
    """The plane x nearest ``guess`` that ``slewed`` turns into exactly (``x``, ``y``), else ``guess``.

    Turning back by the slew is exact in real numbers, not in floats: the plane x comes back a
    few units in the last place off, and a trace written to 6 digits can then differ in its last
    digit from the embedded run's. Trying the floats next to the guess finds the one the turn
    came from, when one maps there exactly (always, for a stand-in that turns with ``slewed``;
    a real CoppeliaSim's numbers have no such x, and the guess stands)."""
    below = above = guess
    for _ in range(ulps + 1):
        for candidate in (below, above) if below != above else (below,):
            sx = axis_x + (candidate - axis_x) * math.cos(slew)
            if sx == x and (candidate - axis_x) * math.sin(slew) == y:
                return candidate
        below, above = math.nextafter(below, -math.inf), math.nextafter(above, math.inf)
    return guess
