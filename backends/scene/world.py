"""Worlds as plain data: walls, blocks and spawn poses, in metres.

A world file (``labsim.backends.scene.world_file`` reads it, with positions for its errors) becomes a frozen
``World``. Backends build their scenes from it, the runtime draws spawn poses from it, and
``labsim plot`` draws it. Nothing here imports a simulator.
"""
from __future__ import annotations

import math
import random
from dataclasses import dataclass, field

from labsim.backends.scene.ground import ROAD_CHANNELS, Ground, Road
from labsim.backends.scene.mechanism import Mechanism
from labsim.backends.scene.models import Kind
from labsim.backends.scene.world_names import BUILTIN_DIR as BUILTIN_DIR  # the one rule for world names;
from labsim.backends.scene.world_names import builtin_worlds as builtin_worlds  # imported from here too

PLACEMENT_CLEARANCE_M = 0.6  # a robot placed 'at: random' is this far from walls and other robots
# What cameras see of walls and blocks when a world file does not say: half a metre, above the
# Pioneer's sonars (0.1 to 0.3 m), as `labsim scene` has always built them in CoppeliaSim. The
# colours are light enough that a threshold for a dark road reads them as not-road, and darker
# than the default floor, so that an edge shows.
WALL_HEIGHT_M = 0.5
WALL_RGB = (175, 175, 170)
BLOCK_HEIGHT_M = 0.5
BLOCK_RGB = (150, 120, 90)


@dataclass(frozen=True)
class Pose:
    x_m: float
    y_m: float
    heading_rad: float


def wrap(angle: float) -> float:
    """The same angle in (-pi, pi]: how every backend reports a heading."""
    a = math.remainder(angle, 2.0 * math.pi)
    return math.pi if a == -math.pi else a


@dataclass(frozen=True)
class Wall:
    """A straight wall: the segment a-b, thickness_m wide (centred on the segment), height_m
    high, seen by cameras in rgb."""

    a: tuple[float, float]
    b: tuple[float, float]
    thickness_m: float
    height_m: float = WALL_HEIGHT_M
    rgb: tuple[int, int, int] = WALL_RGB


@dataclass(frozen=True)
class Block:
    """A solid convex polygon (a box, a pillar), corners counter-clockwise, world frame,
    height_m high, seen by cameras in rgb."""

    corners: tuple[tuple[float, float], ...]
    height_m: float = BLOCK_HEIGHT_M
    rgb: tuple[int, int, int] = BLOCK_RGB


@dataclass(frozen=True)
class World:
    name: str
    description: str
    bounds: tuple[float, float, float, float]  # xmin, ymin, xmax, ymax: where robots may be
    walls: tuple[Wall, ...] = ()
    blocks: tuple[Block, ...] = ()
    spawns: tuple[Pose, ...] = ()
    source: str = field(default="", compare=False)  # the file it came from
    # the SHA-256 of that file's text, taken as it was read: what a trace's header names, so
    # that a run does not read the file a second time (which another writer may have changed)
    sha256: str = field(default="", compare=False)
    # What a camera sees: floor colour, roads, lines, patches.
    ground: Ground | None = None
    # An articulated model (bodies, joints, force sensors) seen from the side, with gravity.
    mechanism: Mechanism | None = None

    def clearance(self, x: float, y: float) -> float:
        """Distance in metres from (x, y) to the nearest wall or block surface (<0 inside)."""
        best = math.inf
        for w in self.walls:
            best = min(best, _segment_distance(x, y, w.a, w.b) - w.thickness_m / 2)
        for bl in self.blocks:
            best = min(best, _polygon_distance(x, y, bl.corners))
        return best

    def random_pose(self, rng: random.Random, clearance_m: float) -> Pose:
        """A pose inside the bounds at least clearance_m from every obstacle.

        Rejection sampling from the caller's generator, so a seed gives the same pose.
        """
        xmin, ymin, xmax, ymax = self.bounds
        for _ in range(10_000):
            x = rng.uniform(xmin + clearance_m, xmax - clearance_m)
            y = rng.uniform(ymin + clearance_m, ymax - clearance_m)
            heading = rng.uniform(-math.pi, math.pi)
            if self.clearance(x, y) >= clearance_m:
                return Pose(x, y, heading)
        raise ValueError(f"world '{self.name}' has no free spot {clearance_m} m clear of obstacles")

    def free_pose(self, rng: random.Random, taken: list[Pose],
                  clearance_m: float = PLACEMENT_CLEARANCE_M) -> Pose | None:
        """A random pose (``random_pose``) also 2 x clearance_m from every pose taken, or None
        when 1000 tries find none: where a robot placed 'at: random' starts."""
        for _ in range(1000):
            try:
                pose = self.random_pose(rng, clearance_m)
            except ValueError:  # no free spot at all, taken or not: trying again will not find one
                return None
            if all(math.hypot(pose.x_m - o.x_m, pose.y_m - o.y_m) >= 2 * clearance_m for o in taken):
                return pose
        return None


def _segment_distance(px: float, py: float, a: tuple[float, float], b: tuple[float, float]) -> float:
    ax, ay = a
    dx, dy = b[0] - ax, b[1] - ay
    length2 = dx * dx + dy * dy
    t = 0.0 if length2 == 0 else max(0.0, min(1.0, ((px - ax) * dx + (py - ay) * dy) / length2))
    return math.hypot(px - ax - t * dx, py - ay - t * dy)


def _polygon_distance(px: float, py: float, corners: tuple[tuple[float, float], ...]) -> float:
    n = len(corners)
    edge = min(_segment_distance(px, py, corners[i], corners[(i + 1) % n]) for i in range(n))
    inside = all(
        (corners[(i + 1) % n][0] - corners[i][0]) * (py - corners[i][1])
        - (corners[(i + 1) % n][1] - corners[i][1]) * (px - corners[i][0]) >= 0
        for i in range(n)
    )
    return -edge if inside else edge


def world_channels(world: World) -> dict[str, Kind]:
    """The channels a world offers robots beyond their model's own: the road's, or none."""
    return dict(ROAD_CHANNELS) if first_road(world) is not None else {}


def first_road(world: World) -> Road | None:
    """The road the road channels refer to, or None when the world has none."""
    ground = world.ground
    return ground.roads[0] if ground is not None and ground.roads else None
