"""A mechanism's pose at each tick of a trace, and its drawing: the crane as it moved.

A stage after the run, used by the still map (``labsim.runtime.pictures.plot``: the final pose with the
start as a ghost, and a top-view inset of the slew) and by the animation
(``labsim.runtime.pictures.animate``: each frame's pose). A trace records what the behaviour reads, so
the pose is put together from what it has:

- the last moving body (the crane's load) from the trace's ``x`` and ``y``, always there;
- any moving body whose ``Body.x`` or ``Body.z`` a ``let:`` reads (``crab_x: Crab.x``), and
  the child of a rail whose ``Joint.position`` one reads, from that column; bodies welded to
  it (``fixed`` joints: the crab's guide) move with it;
- a body hanging on a rope that no column places (the hook) between the rope's end and the
  body below it (the load), at the distance they started at;
- the slew angle from a column reading the slew joint's ``position``.

A body nothing places is drawn where it started, and the note says so. The ``let:`` lines are
read from the behaviour file the trace names; without it only the load moves.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass

import cv2
import numpy as np

from labsim.backends.scene.mechanism import Mechanism
from labsim.runtime.pictures.paint import AA, BLOCK_EDGE, BLOCK_FILL, INK, MUTED, ONE, PAPER, SHIFT, Painter, PxMap
from labsim.runtime.pictures.trace_behaviour import behaviour_data
from labsim.runtime.trace import Trace

GHOST = (200, 200, 200)
_SOURCE = re.compile(r"^\s*([A-Za-z_][A-Za-z0-9_]*)\.(x|z|position)\s*$")


@dataclass
class Poses:
    """Per trace row: every moving body's displacement from its start, and the slew angle."""

    offsets: dict[str, np.ndarray]  # body -> (n, 2) metres
    slew: np.ndarray | None  # (n,) radians, None when no column reads it
    unplaced: list[str]  # moving bodies drawn where they started


def _lets(trace: Trace) -> dict[str, tuple[str, str]]:
    """Trace column -> (object, "x" | "z" | "position") for lets that read one thing plainly."""
    _, doc = behaviour_data(trace)
    lets = doc.get("let") if isinstance(doc, dict) else None
    out = {}
    for name, expr in (lets or {}).items():
        m = _SOURCE.match(str(expr))
        if m and name in trace.columns:
            out[str(name)] = (m.group(1), m.group(2))
    return out


def _column(trace: Trace, name: str) -> np.ndarray:
    i = trace.columns.index(name)
    return np.array([float(r[i]) for r in trace.rows], float)


def _welded(mech: Mechanism) -> dict[str, str]:
    """Each body -> the first body of the group rigidly joined to it (fixed joints)."""
    root = {b.name: b.name for b in mech.bodies}

    def find(a: str) -> str:
        while root[a] != a:
            a = root[a]
        return a

    for j in mech.joints:
        if j.kind == "fixed":
            root[find(j.child)] = find(j.parent)
    return {b: find(b) for b in root}


def mechanism_poses(trace: Trace, mech: Mechanism) -> Poses:
    """Every moving body's displacement at every row; see the module's docstring for how."""
    # one pass over the ways a pose is known, in the order the docstring gives them
    n = len(trace.rows)
    group = _welded(mech)
    start = {b.name: np.array(b.center, float) for b in mech.bodies}
    moving = [b.name for b in mech.bodies if not b.static]
    known: dict[str, np.ndarray] = {}  # group root -> (n, 2) offset
    slew = None
    if moving and "x" in trace.columns and "y" in trace.columns:
        last = moving[-1]
        known[group[last]] = np.column_stack((_column(trace, "x"), _column(trace, "y"))) - start[last]
    joints = {j.name: j for j in mech.joints}
    for col, (obj, what) in _lets(trace).items():
        v = _column(trace, col)
        if obj in start and what in "xz" and group[obj] not in known:
            off = np.zeros((n, 2))
            off[:, "xz".index(what)] = v - start[obj]["xz".index(what)]
            known[group[obj]] = off
        elif obj in joints and what == "position":
            j = joints[obj]
            if j.kind == "slew":
                slew = v
            elif j.kind == "prismatic" and not j.rope and group[j.child] not in known:
                known[group[j.child]] = np.outer(v - v[0], np.array(j.axis, float))
    for j in mech.joints:  # a body on a rope hangs between the rope's end and what it holds
        g = group[j.child]
        if not j.rope or g in known or group[j.parent] not in known:
            continue
        held = next((s.between[1] if s.between[0] == j.child else s.between[0] for s in mech.force_sensors
                     if j.child in s.between), None)
        if held is None or group[held] not in known:
            continue
        top = np.array(j.anchor, float) + known[group[j.parent]]
        below = start[held] + known[group[held]]
        d0 = float(np.hypot(*(start[j.child] - start[held])))
        u = top - below
        u /= np.maximum(np.hypot(u[:, 0], u[:, 1]), 1e-9)[:, None]
        known[g] = below + d0 * u - start[j.child]
    offsets = {b: known.get(group[b], np.zeros((n, 2))) for b in moving}
    unplaced = [b for b in moving if group[b] not in known]
    return Poses(offsets, slew, unplaced)


def draw_pose(img: np.ndarray, mech: Mechanism, poses: Poses | None, i: int, px: PxMap, P: Painter, *,
              ghost: bool = False, fixed: bool = True) -> None:
    """The mechanism at row ``i`` (the start when poses is None): the floor and fixed bodies
    (unless ``fixed`` is False), each rope, and the moving bodies filled; a ghost is outlines."""
    def off(name: str) -> np.ndarray:
        if poses is None or name not in poses.offsets:
            return np.zeros(2)
        return poses.offsets[name][i]

    def poly(name: str) -> np.ndarray:
        b = mech.body(name)
        return np.round(px(np.array(b.corners(), float) + off(name)) * ONE).astype(np.int32)

    if fixed:
        if mech.floor_z_m is not None:
            xs = [c[0] for b in mech.bodies for c in b.corners()]
            ends = np.round(px(np.array([[min(xs) - 1.0, mech.floor_z_m], [max(xs) + 1.0, mech.floor_z_m]])))
            cv2.line(img, tuple(ends[0].astype(int)), tuple(ends[1].astype(int)), BLOCK_EDGE, max(2, P.lw), AA)
        for b in mech.bodies:
            if b.static:
                cv2.fillPoly(img, [poly(b.name)], BLOCK_FILL, AA, SHIFT)
                cv2.polylines(img, [poly(b.name)], True, BLOCK_EDGE, P.lw, AA, SHIFT)
    edge = GHOST if ghost else INK
    for j in mech.joints:
        if j.rope:
            child = mech.body(j.child)
            ends = np.array([np.array(j.anchor) + off(j.parent),
                             np.array((child.center[0], child.center[1] + child.size[1] / 2)) + off(j.child)])
            a = np.round(px(ends) * ONE).astype(np.int32)
            cv2.line(img, tuple(a[0]), tuple(a[1]), edge if ghost else MUTED, max(1, P.lw), AA, SHIFT)
    for s in mech.force_sensors:  # the sling, centre to centre
        a = np.round(px(np.array([mech.body(s.between[0]).center, mech.body(s.between[1]).center], float)
                        + np.array([off(s.between[0]), off(s.between[1])])) * ONE).astype(np.int32)
        cv2.line(img, tuple(a[0]), tuple(a[1]), edge if ghost else MUTED, 1, AA, SHIFT)
    for b in mech.bodies:
        if not b.static:
            if not ghost:
                cv2.fillPoly(img, [poly(b.name)], (225, 190, 150), AA, SHIFT)
            cv2.polylines(img, [poly(b.name)], True, edge, max(1, P.lw), AA, SHIFT)


def slew_inset(img: np.ndarray, P: Painter, mech: Mechanism, trace: Trace, box: tuple[int, int, int],
               i: int = -1, poses: Poses | None = None) -> None:
    """A top view: the arm at row ``i``'s slew angle, its start as a ghost, the swept arc.

    ``box`` is (left, top, size) in pixels. The arm's length and side follow the mechanism:
    from the slew axis to the far end of the body the slew joint turns.
    """
    slew = (poses or mechanism_poses(trace, mech)).slew
    if slew is None:
        return
    i = i % len(slew)
    x, y, size = box
    cv2.rectangle(img, (x, y), (x + size, y + size), PAPER, -1)
    cv2.rectangle(img, (x, y), (x + size, y + size), BLOCK_EDGE, P.lw)
    j = next(j for j in mech.joints if j.kind == "slew")
    arm = mech.body(j.child)
    xs = [c[0] - j.anchor[0] for c in arm.corners()]
    reach = max(abs(min(xs)), abs(max(xs)))
    r = 0.4 * size / reach
    c = np.array([x + size / 2, y + size / 2 + 6 * P.s])

    def arm_line(angle: float, colour: tuple[int, int, int], width: int) -> None:
        u = np.array([math.cos(angle), -math.sin(angle)])  # seen from above: x right, y up
        a, b = c + min(xs) * r * u, c + max(xs) * r * u
        cv2.line(img, tuple(np.round(a * ONE).astype(int)), tuple(np.round(b * ONE).astype(int)), colour, width,
                 AA, SHIFT)

    arm_line(float(slew[0]), GHOST, max(3, round(4 * P.s)))
    lo, hi = float(np.nanmin(slew[: i + 1])), float(np.nanmax(slew[: i + 1]))
    if hi - lo > 1e-3:
        rad = round(max(xs) * r * 0.55)
        cv2.ellipse(img, tuple(np.round(c).astype(int)), (rad, rad), 0, -math.degrees(hi), -math.degrees(lo),
                    (40, 140, 230), max(2, P.lw), AA)
    arm_line(float(slew[i]), INK, max(3, round(4 * P.s)))
    cv2.circle(img, tuple(np.round(c).astype(int)), max(3, round(4 * P.s)), BLOCK_EDGE, -1, AA)
    P.put(img, "from above", (x + 6 * P.s, y + 16 * P.s), P.small, MUTED)
    a = float(slew[i])
    P.put(img, f"slew {a:.2f} rad ({math.degrees(a):.0f} deg)", (x + 6 * P.s, y + size - 8 * P.s), P.small, INK)


def has_slew(trace: Trace, mech: Mechanism) -> bool:
    """Whether the trace has a slew angle to show: a column reads the slew joint, and it moved."""
    if not trace.rows or not any(j.kind == "slew" for j in mech.joints):
        return False
    slew = mechanism_poses(trace, mech).slew
    return slew is not None and bool(np.nanmax(np.abs(slew - slew[0])) > 1e-3)


def drawn_without(trace: Trace, mech: Mechanism) -> list[str]:
    """What a picture of the mechanism lacks when the behaviour file is not there to say which
    columns place its bodies and turn its slew: the slew panel, and the moves of each rigid
    group of bodies (named by its first body) that stays where it started."""
    poses = mechanism_poses(trace, mech)
    out = []
    if poses.slew is None and any(j.kind == "slew" for j in mech.joints):
        out.append("the slew panel")
    group = _welded(mech)
    still = list(dict.fromkeys(group[b] for b in poses.unplaced))
    if still:
        out.append("the moves of " + (still[0] if len(still) == 1 else ", ".join(still[:-1]) + " and " + still[-1]))
    return out


def draw_run_mechanism(img: np.ndarray, P: Painter, mech: Mechanism, trace: Trace, px: PxMap,
                       backdrop: bool) -> None:
    """The still map's mechanism: the start as a ghost under the final pose; a backdrop (what
    an animation draws on) gets the fixed parts and the start's ghost only."""
    if backdrop or not trace.rows:
        draw_pose(img, mech, None, 0, px, P, ghost=backdrop)
        return
    poses = mechanism_poses(trace, mech)
    draw_pose(img, mech, None, 0, px, P, ghost=True)
    draw_pose(img, mech, poses, len(trace.rows) - 1, px, P, fixed=False)
