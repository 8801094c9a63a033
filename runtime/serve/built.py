"""What the stand-in's scene editing builds: shapes and vision sensors, as plain data.

``scene_edit`` makes them from remote calls, ``mechanism_edit`` reads a mechanism back from
them; both import them from here, so neither imports the other for its data.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any


@dataclass(eq=False)
class Shape:
    """A shape built through the remote API, in the world frame."""

    kind: str  # plane | cuboid | cylinder | mesh | texture
    size: tuple[float, float, float]
    corners: tuple[tuple[float, float], ...] = ()  # a mesh's outline at the floor
    x: float = 0.0
    y: float = 0.0
    z: float = 0.0
    yaw: float = 0.0
    alias: str = "Cuboid"
    static: bool = False
    respondable: bool = False  # robots collide with it (a static or respondable shape is an obstacle)
    png: bytes = b""  # a textured plane's picture (sim.createTexture)
    px: tuple[int, int] = (0, 0)  # its width and height in pixels


@dataclass(eq=False)
class Sensor:
    """A vision sensor built through the remote API: it becomes its robot's camera."""

    resolution: tuple[int, int]
    angle_rad: float  # the view angle, across the larger side
    robot: int = -1  # the robot it was parented to
    matrix: list[float] = field(default_factory=list)  # its pose in the robot's frame
    alias: str = "visionSensor"


def shape_options(args: list[Any]) -> dict[str, bool]:
    """sim.createPrimitiveShape's options (CoppeliaSim 4.6 manual): bit 3 respondable, bit 4 static."""
    options = args[2] if len(args) > 2 and isinstance(args[2], int) and not isinstance(args[2], bool) else 0
    return {"respondable": bool(options & 8), "static": bool(options & 16)}
