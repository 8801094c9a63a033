"""CoppeliaSim's 3D transforms for the stand-in: 3 x 4 matrices, quaternions and Euler angles.

Where it sits: pure arithmetic under ``sim_objects``, which answers ``sim.getObjectMatrix``,
``sim.buildMatrix``, ``sim.getObjectQuaternion`` and the poses of dummies (which, having no
physics, may stand anywhere in 3D). A matrix is CoppeliaSim's 12 numbers, row by row: ``[r11,
r12, r13, x, r21, r22, r23, y, r31, r32, r33, z]``; a quaternion is ``(x, y, z, w)``; Euler
angles (alpha, beta, gamma) rotate about x, then the new y, then the new z, so R = Rx Ry Rz
(manual: "Position, orientation and transformation"; ``backends/coppeliasim/frames.py``).
"""
from __future__ import annotations

import math
from collections.abc import Sequence

Matrix = list[float]  # 12 numbers
IDENTITY: Matrix = [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0]


def from_euler(position: Sequence[float], euler: Sequence[float]) -> Matrix:
    """sim.buildMatrix: the matrix of a position and Euler angles (R = Rx(a) Ry(b) Rz(g))."""
    a, b, g = euler
    ca, sa, cb, sb, cg, sg = math.cos(a), math.sin(a), math.cos(b), math.sin(b), math.cos(g), math.sin(g)
    return [cb * cg, -cb * sg, sb, float(position[0]),
            ca * sg + sa * sb * cg, ca * cg - sa * sb * sg, -sa * cb, float(position[1]),
            sa * sg - ca * sb * cg, sa * cg + ca * sb * sg, ca * cb, float(position[2])]


def euler(m: Matrix) -> list[float]:
    """The Euler angles of a matrix's rotation (the inverse of ``from_euler``)."""
    b = math.asin(max(-1.0, min(1.0, m[2])))
    if abs(m[2]) < 1.0 - 1e-12:
        return [math.atan2(-m[6], m[10]), b, math.atan2(-m[1], m[0])]
    return [math.atan2(m[9], m[5]), b, 0.0]  # gimbal lock: alpha takes the whole turn about x


def from_pose(pose: Sequence[float]) -> Matrix:
    """The matrix of a pose ``[x, y, z, qx, qy, qz, qw]``."""
    x, y, z, qx, qy, qz, qw = (float(v) for v in pose)
    n = math.sqrt(qx * qx + qy * qy + qz * qz + qw * qw) or 1.0
    qx, qy, qz, qw = qx / n, qy / n, qz / n, qw / n
    return [1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qz * qw), 2 * (qx * qz + qy * qw), x,
            2 * (qx * qy + qz * qw), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - qx * qw), y,
            2 * (qx * qz - qy * qw), 2 * (qy * qz + qx * qw), 1 - 2 * (qx * qx + qy * qy), z]


def quaternion(m: Matrix) -> list[float]:
    """The unit quaternion ``[qx, qy, qz, qw]`` of a matrix's rotation (qw >= 0)."""
    r11, r12, r13, r21, r22, r23, r31, r32, r33 = m[0], m[1], m[2], m[4], m[5], m[6], m[8], m[9], m[10]
    t = r11 + r22 + r33
    if t > 0:
        s = math.sqrt(t + 1.0) * 2
        q = [(r32 - r23) / s, (r13 - r31) / s, (r21 - r12) / s, s / 4]
    elif r11 > r22 and r11 > r33:
        s = math.sqrt(1.0 + r11 - r22 - r33) * 2
        q = [s / 4, (r12 + r21) / s, (r13 + r31) / s, (r32 - r23) / s]
    elif r22 > r33:
        s = math.sqrt(1.0 + r22 - r11 - r33) * 2
        q = [(r12 + r21) / s, s / 4, (r23 + r32) / s, (r13 - r31) / s]
    else:
        s = math.sqrt(1.0 + r33 - r11 - r22) * 2
        q = [(r13 + r31) / s, (r23 + r32) / s, s / 4, (r21 - r12) / s]
    return [-v for v in q] if q[3] < 0 else q


def pose(m: Matrix) -> list[float]:
    """``[x, y, z, qx, qy, qz, qw]`` of a matrix."""
    return [m[3], m[7], m[11], *quaternion(m)]


def times(a: Matrix, b: Matrix) -> Matrix:
    """a b: the frame b, given in a's frame, in a's parent's."""
    out: Matrix = []
    for r in range(3):
        row = a[4 * r:4 * r + 3]
        out += [sum(row[k] * b[4 * k + c] for k in range(3)) for c in range(3)]
        out.append(sum(row[k] * b[4 * k + 3] for k in range(3)) + a[4 * r + 3])
    return out


def inverse(m: Matrix) -> Matrix:
    """The inverse of a rigid transform."""
    rt = [m[0], m[4], m[8], m[1], m[5], m[9], m[2], m[6], m[10]]  # the rotation transposed
    p = (m[3], m[7], m[11])
    out: Matrix = []
    for r in range(3):
        row = rt[3 * r:3 * r + 3]
        out += [*row, -sum(row[k] * p[k] for k in range(3))]
    return out


def seen_from(m: Matrix, ref: Matrix) -> Matrix:
    """m (world frame) in the frame of ref (world frame)."""
    return times(inverse(ref), m)
