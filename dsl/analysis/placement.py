"""Where each robot starts: the one rule for robot placement, applied when a behaviour compiles.

Robots are named and placed in the file's order: a group of ``count`` robots is ``name[0]``,
``name[1]``, ...; ``at: spawn`` takes the world's spawn poses in order, ``at: random`` a free
pose drawn from the behaviour's seed (``random.Random(f"{seed}/placement")``) clear of every pose the
file gives, and a fixed ``[x, y, heading_deg]`` is that pose. The compiler places them once: the ``Program`` carries
the start poses the runtime opens the world with, and a robot that finds no place is an error
at its line, before anything is simulated.
"""
from __future__ import annotations

import math
import random
from dataclasses import dataclass

from labsim.backends.scene.world import PLACEMENT_CLEARANCE_M, Pose
from labsim.dsl.analysis.check import Checked
from labsim.foundation.diagnostics import Diagnostic


@dataclass(frozen=True)
class Start:
    """One robot of the behaviour and where it starts."""

    name: str  # "pioneer", or "rover[2]" for the third robot of a group
    group: int  # its entry of ``robots:`` (Program.robots)
    index: int  # its place in that group
    pose: Pose


def robot_name(group: str, count: int, k: int) -> str:
    """A robot's name: the group's for a group of one, ``group[k]`` otherwise."""
    return group if count == 1 else f"{group}[{k}]"


def place(c: Checked, seed: int) -> tuple[tuple[Start, ...], Diagnostic | None]:
    """Every robot's start, and the error for the first robot that finds no place (then the
    starts stop there).

    The poses the file gives (``[x, y, heading_deg]``, a list of them, ``spawn``) are known first: a
    robot placed at random keeps clear of every one of them, wherever its group is declared, and of
    the random ones drawn before it. The draws are made in the file's order, so a file whose random
    robots come last (or meet no given pose) starts where it always did."""
    world = c.world
    assert world is not None  # the checker reports a missing world as an error
    given, unplaced = _given_poses(c)
    rng = random.Random(f"{seed}/placement")
    starts: list[Start] = []
    avoid = list(given.values())
    for g, decl in enumerate(c.file.robots):
        for k in range(decl.count):
            name = robot_name(decl.name, decl.count, k)
            if unplaced is not None and (g, k) == unplaced[0]:
                return tuple(starts), unplaced[1]
            pose = given.get((g, k))
            if pose is None:
                pose = world.free_pose(rng, avoid, PLACEMENT_CLEARANCE_M)
                if pose is None:
                    return tuple(starts), c.file.doc.diagnostic(
                        decl.key, f"no free place left in world '{world.name}' for robot '{name}' "
                        f"({len(starts)} robots fit, each {PLACEMENT_CLEARANCE_M:g} m from walls and "
                        f"{2 * PLACEMENT_CLEARANCE_M:g} m from the others)",
                        notes=("use fewer robots, or give their poses as [x, y, heading_deg]",))
                avoid.append(pose)
            starts.append(Start(name, g, k, pose))
    return tuple(starts), None


def _given_poses(c: Checked) -> tuple[dict[tuple[int, int], Pose], tuple[tuple[int, int], Diagnostic] | None]:
    """The poses the file gives, by (group, place in it): fixed ones, and the world's spawn poses in the
    file's order; and the first robot the spawn poses are too few for, with its error."""
    world = c.world
    assert world is not None
    spawns = list(world.spawns)
    out: dict[tuple[int, int], Pose] = {}
    for g, decl in enumerate(c.file.robots):
        for k in range(decl.count):
            if decl.at == "spawn":
                if not spawns:
                    name = robot_name(decl.name, decl.count, k)
                    notes = ("use 'at: random', or fewer robots",) if c.file.version < 1.3 else (
                        "use 'at: random', fewer robots, or a pose for each robot: 'at: [[x, y, heading_deg], ...]'",)
                    return out, ((g, k), c.file.doc.diagnostic(
                        decl.key, f"world '{world.name}' has {len(world.spawns)} spawn poses, too few for "
                                  f"robot '{name}'", notes=notes))
                out[g, k] = spawns.pop(0)
            elif decl.at != "random":
                fixed = decl.start(k)
                assert fixed is not None
                out[g, k] = Pose(fixed[0], fixed[1], math.radians(fixed[2]))
    return out, None
