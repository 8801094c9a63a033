"""Robot models as plain data, shared by every backend and by the checker.

A model says which sensor channels a robot offers (the names a behaviour may read), how its
wheels drive it, and where its sensors sit. Nothing here imports a simulator: the pymunk
backend turns these numbers into bodies and ray casts, the CoppeliaSim backend into object
paths, and the checker into the set of known sensor names.

Frames: x forward, y to the left, angles counter-clockwise from x, in radians. SI units.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum
from typing import Any


class Kind(Enum):
    """What a channel's value is."""

    DISTANCE = "distance"  # metres; math.inf when nothing is detected
    NUMBER = "number"
    BOOL = "bool"
    IMAGE = "image"  # numpy uint8 array, height x width x 3, RGB; row 0 is the bottom (see Camera)
    JOINT = "joint"  # (position m or rad, velocity m/s or rad/s)
    FORCE = "force"  # (tension N,)
    BODY = "body"  # (x_m, z_m, angle_rad) in a mechanism's vertical plane


@dataclass(frozen=True)
class Sonar:
    """One ultrasonic sensor, modelled as a single ray from its mount along its axis."""

    name: str  # channel name, 1-based as CoppeliaSim's legacy API: sonar1..sonar16
    x_m: float
    y_m: float
    angle_rad: float
    range_m: float


@dataclass(frozen=True)
class Camera:
    """A forward-looking vision sensor on a robot, seeing the world's ground and the robots,
    walls and blocks standing on it.

    The image is RGB, ``height_px`` rows by ``width_px`` columns, in CoppeliaSim's row order:
    row 0 is the BOTTOM row of the picture (the near edge of the floor), column 0 the left.
    It is the array ``sim.getVisionSensorImg`` hands a script, so a behaviour and a script
    written for CoppeliaSim read the same numbers; whatever shows an image to a person turns
    it upright with ``upright`` (docs/decisions.md, "Camera images in CoppeliaSim's row
    order"). The camera sits ``x_m`` ahead of the robot's origin, ``height_m`` above the
    floor, looking forward and down by ``pitch_deg``, and turned about its viewing axis by
    ``roll_deg``: positive turns the picture's top edge towards the robot's right, as seen
    from behind the camera (at -90 the rows run across the way ahead, row 0 on the right).
    """

    name: str  # channel name, e.g. "camera"
    width_px: int
    height_px: int
    fov_deg: float  # horizontal field of view
    height_m: float
    pitch_deg: float  # below the horizontal
    x_m: float = 0.2
    roll_deg: float = 0.0  # about the viewing axis; + turns the image's top towards the right

    @property
    def vertical_fov_deg(self) -> float:
        half = math.atan(math.tan(math.radians(self.fov_deg) / 2) * self.height_px / self.width_px)
        return math.degrees(2 * half)


def upright(image: Any) -> Any:
    """A camera image (or an image made from one) as a person looks at it: top row first.

    Images run bottom row first, as CoppeliaSim sends them, so every picture shown to a
    person (the live view, ``labsim plot --camera``, a written PNG) goes through this one
    flip, and nothing a behaviour reads does. A view, not a copy: OpenCV wants
    ``np.ascontiguousarray`` of it.
    """
    return image[::-1]


@dataclass(frozen=True)
class RobotModel:
    name: str
    description: str
    wheel_radius_m: float
    axle_length_m: float  # distance between the two wheels' contact points
    max_wheel_speed_rad_s: float  # wheel commands beyond this are clamped (and counted)
    mass_kg: float
    footprint: tuple[tuple[float, float], ...]  # convex outline in the robot frame, metres
    sonars: tuple[Sonar, ...]
    cameras: tuple[Camera, ...] = ()  # none on the stock model; a behaviour file adds them
    # What other robots' cameras see of it: its footprint raised to height_m, in rgb (0..255).
    height_m: float = 0.2
    rgb: tuple[int, int, int] = (128, 128, 128)

    def channels(self) -> dict[str, Kind]:
        """Every channel a behaviour may read from a robot of this model, in a stable order."""
        out: dict[str, Kind] = {s.name: Kind.DISTANCE for s in self.sonars}
        out.update({c.name: Kind.IMAGE for c in self.cameras})
        out.update(POSE_CHANNELS)
        out["forward_speed"] = Kind.NUMBER  # m/s along the heading
        out["collided"] = Kind.BOOL
        return out


# Every robot reports its pose; the runtime also writes it to the trace.
POSE_CHANNELS: dict[str, Kind] = {"x": Kind.NUMBER, "y": Kind.NUMBER, "heading": Kind.NUMBER}


# --- Pioneer P3DX ---------------------------------------------------------------------------
# Sources, in order of trust (see ../shared/reference/coppeliasim-zmq-protocol.md, section 6):
# * Sonar poses and angles: course code reproducing CoppeliaSim's model (`robot_p3dx.py`,
#   SENSORS list); the angles match the real robot's sonar ring (90, 50, 30, 10, -10, ...).
# * Wheel radius 0.0975 m (wheel diameter 195 mm): the same course code and the Pioneer 3
#   datasheet agree.
# * Axle length 0.331 m: uncertain, third-party figures range 0.311..0.381; 0.331 is the
#   half-axle 0.1655 seen in code written against CoppeliaSim's model.
# * Sonar range 1.0 m: uncertain (the course code's SENSOR_RANGE); the model's own
#   Braitenberg script needs only 0.5 m.
# * Max wheel speed 12.3 rad/s: the real P3DX's 1.2 m/s top speed / 0.0975 m. CoppeliaSim's
#   model sets no joint velocity limit that could be confirmed, so this is the real robot's.
# * Mass 9 kg: the Pioneer 3 datasheet (robot without batteries).
# * Footprint: the chassis outline through the sonar mounts (which sit on its edge) plus the
#   wheels, 0.42 m long and 0.38 m wide (datasheet: 455 x 381 mm including the bumpers).
# * Height 0.237 m: the Pioneer 3 datasheet's 237 mm (body, without accessories); what other
#   robots' cameras see is the footprint raised to this height.
# * Colour red (200, 30, 30): the real robot's and CoppeliaSim's model's red body; the shade is
#   a choice, not a measured figure.
_P3DX_SONARS = (
    (0.1067, 0.1382, 90), (0.1557, 0.1250, 50), (0.1909, 0.0831, 30), (0.2095, 0.0273, 10),
    (0.2095, -0.0273, -10), (0.1909, -0.0785, -30), (0.1558, -0.1203, -50), (0.1067, -0.1382, -90),
    (-0.1100, -0.1382, -90), (-0.1593, -0.1203, -130), (-0.1943, -0.0785, -150), (-0.2129, -0.0273, -170),
    (-0.2129, 0.0273, 170), (-0.1943, 0.0785, 150), (-0.1593, 0.1203, 130), (-0.1100, 0.1382, 90),
)

PIONEER_P3DX = RobotModel(
    name="pioneer_p3dx",
    description="Pioneer P3DX: differential drive, 16 ultrasonic sonars",
    wheel_radius_m=0.0975,
    axle_length_m=0.331,
    max_wheel_speed_rad_s=12.3,
    mass_kg=9.0,
    footprint=(
        (0.2095, 0.0273), (0.2095, -0.0273), (0.1909, -0.0831), (0.1558, -0.1250),
        (0.0975, -0.19), (-0.0975, -0.19), (-0.1593, -0.1203), (-0.1943, -0.0785),
        (-0.2129, -0.0273), (-0.2129, 0.0273), (-0.1943, 0.0785), (-0.1593, 0.1203),
        (-0.0975, 0.19), (0.0975, 0.19), (0.1557, 0.1250), (0.1909, 0.0831),
    ),
    sonars=tuple(
        Sonar(f"sonar{i + 1}", x, y, math.radians(a), 1.0) for i, (x, y, a) in enumerate(_P3DX_SONARS)
    ),
    height_m=0.237,
    rgb=(200, 30, 30),
)

MODELS: dict[str, RobotModel] = {m.name: m for m in (PIONEER_P3DX,)}
