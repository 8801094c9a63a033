"""Robots given start poses on top of each other: an error, before anything is simulated.

Robots that start overlapping all touch each other: n of them are n(n-1)/2 contacts on every
step, and the embedded simulator spends its time resolving them (1000 robots on one spot took
about a second of wall time per tick). Robots that start apart can only touch their few
neighbours, whatever they do later. So a group of several robots at one fixed pose, and a
robot whose fixed or spawn pose is within another's reach (its centre closer than the smaller of the
two models' reach, the farthest point of the footprint), are reported at the robot's ``at:``.

The check is linear: poses go into a grid of cells as wide as two robots, and each is
compared with the robots of its own and the neighbouring cells only.
"""
from __future__ import annotations

import math

from labsim.dsl.analysis.check import Checked
from labsim.dsl.analysis.placement import Start
from labsim.foundation.diagnostics import Report


def check_crowd(c: Checked, starts: tuple[Start, ...], report: Report) -> None:
    """Report robot groups and robots whose fixed start poses overlap."""
    placed: list[tuple[float, float, float, str]] = []  # x, y, reach, name
    for g, decl in enumerate(c.file.robots):
        model = c.models.get(decl.name)
        if model is None or decl.at == "random":
            continue
        reach = max((math.hypot(px, py) for px, py in model.footprint), default=0.0)
        if decl.at == "spawn":  # the world's spawn poses, where the placement put them
            placed += [(s.pose.x_m, s.pose.y_m, reach, s.name) for s in starts if s.group == g]
            continue
        assert not isinstance(decl.at, str)
        where = decl.at_node if decl.at_node is not None else decl.key
        if isinstance(decl.at[0], tuple):  # format 1.3: a pose per member
            placed += [(x, y, reach, s.name) for ((x, y, _), _), s in zip(decl.fixed(), (s for s in starts
                                                                                      if s.group == g))]
            continue
        x, y, _ = decl.fixed()[0][0]
        if decl.count > 1:
            report.add(c.file.doc.diagnostic(
                where, f"the {decl.count} robots of '{decl.name}' would all start at ({x:g}, {y:g}), "
                       "on top of each other",
                notes=("give a group 'at: random' or 'at: spawn', or each robot its own entry and pose",)
                if c.file.version < 1.3 else (f"give each robot its own pose, as in 'at: [[{x:g}, {y:g}], "
                                              f"[{x + 1:g}, {y:g}], ...]', or the group 'at: random' or 'at: spawn'",)))
            continue
        placed.append((x, y, reach, decl.name))
    for (x, y, reach, name), (ox, oy, other_reach, other) in _overlaps(placed):
        decl = next(d for d in c.file.robots if d.name == name.partition("[")[0])
        where = decl.at_node if decl.at_node is not None else decl.key
        if not isinstance(decl.at, str) and isinstance(decl.at[0], tuple):  # the member's own pose
            where = decl.fixed()[int(name.partition("[")[2].rstrip("]") or 0)][1]
        report.add(c.file.doc.diagnostic(
            where, f"robot '{name}' would start {math.hypot(x - ox, y - oy):.2f} m from robot '{other}', "
                   f"overlapping it (they reach {reach:.2f} m and {other_reach:.2f} m from their centres)",
            notes=("the world's spawn poses are too close together: use 'at: random', or a world with its "
                   "spawn poses apart" if decl.at == "spawn" else "move one of them into the open",)))


def _overlaps(placed: list[tuple[float, float, float, str]]
              ) -> list[tuple[tuple[float, float, float, str], tuple[float, float, float, str]]]:
    """Each robot that overlaps one placed before it, with the first such robot."""
    if not placed:
        return []
    cell = 2 * max(r for _, _, r, _ in placed) or 1.0
    grid: dict[tuple[int, int], list[tuple[float, float, float, str]]] = {}
    out = []
    for robot in placed:
        x, y, reach, _ = robot
        cx, cy = math.floor(x / cell), math.floor(y / cell)
        near = (o for dx in (-1, 0, 1) for dy in (-1, 0, 1) for o in grid.get((cx + dx, cy + dy), ()))
        # centres closer than the smaller reach: deep in each other, not merely grazing a corner
        hit = next((o for o in near if math.hypot(x - o[0], y - o[1]) < min(reach, o[2])), None)
        if hit is not None:
            out.append((robot, hit))
        grid.setdefault((cx, cy), []).append(robot)
    return out
