"""A robot group's ``lidar:`` key, read into a ``Lidar`` of the robot's model.

Part of reading a behaviour file: ``labsim.dsl.syntax.read`` calls ``read_lidar`` for each robot
group that has the key, and the checker puts the lidar on the group's model (as it does a
``camera:``), so its beams become channels ``lidar1`` .. ``lidarN`` that rules read alone or as
a group (``lidar1..lidar360``). The key table and limits live here, and the JSON Schema is
built from them (``labsim.dsl.syntax.schema``). Every problem is reported at its key or value.
"""
from __future__ import annotations

from yaml.nodes import Node

from labsim.backends.scene.models import Lidar
from labsim.foundation.source import Reader

LIDAR_KEYS = ("beams", "fov_deg", "range_m", "noise", "x_m")
MAX_BEAMS = 1440  # each beam is a channel and a ray a tick; a quarter-degree circle is the most
# key -> (lowest, highest, default, what it is)
LIDAR_LIMITS: dict[str, tuple[float, float, float, str]] = {
    "beams": (1, MAX_BEAMS, 360, "how many beams (channels lidar1 .. lidarN), the first the rightmost"),
    "fov_deg": (1, 360, 360, "the fan's width in degrees, centred ahead; 360 is a full circle"),
    "range_m": (0.01, 100, 5.0, "the farthest a beam sees, in metres; beyond it a beam reads inf"),
    "noise": (0, 10, 0.0, "standard deviation of the Gaussian noise added to each echo, in metres"),
    "x_m": (-1, 1, 0.0, "how far ahead of the robot's centre the scanner sits, in metres"),
}


def beam_names(beams: int) -> list[str]:
    """The channels of a lidar with this many beams: lidar1 .. lidarN."""
    return [f"lidar{k}" for k in range(1, beams + 1)]


def read_lidar(r: Reader, node: Node, robot: str) -> Lidar | None:
    """``lidar: {beams: 360, fov_deg: 360, range_m: 5, noise: 0.01}``; None after an error."""
    fields = r.fields(node, LIDAR_KEYS, f"the lidar of robot '{robot}' (keys: {', '.join(LIDAR_KEYS)})")
    if fields is None:
        return None
    values = {key: limits[2] for key, limits in LIDAR_LIMITS.items()}
    ok = True
    for key, value in fields.items():
        lo, hi, _, _ = LIDAR_LIMITS[key]
        v = r.number(value, f"lidar {key}", integer=key == "beams")
        if v is None:
            ok = False
        elif not lo <= v <= hi:
            r.error(value, f"lidar {key} must be between {lo:g} and {hi:g}, not {v:g}")
            ok = False
        else:
            values[key] = v
    if not ok:
        return None
    return Lidar(int(values["beams"]), values["fov_deg"], values["range_m"], values["noise"], values["x_m"])
