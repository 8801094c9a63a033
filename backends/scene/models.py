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
    CONTACT = "contact"  # a bumper: True while its part of the chassis touches something
    REFLECTANCE = "reflectance"  # a ground sensor: 0 (black floor) .. 1 (white), no unit


# How many rays stand for a sonar's cone, spread evenly from one edge to the other; the
# reasons for 5 are in docs/decisions.md §24.
CONE_RAYS = 5


@dataclass(frozen=True)
class Sonar:
    """One range sensor from its mount along its axis: a sonar, an IR proximity sensor (the
    e-puck's prox1..prox8) or one beam of a lidar (``Lidar.rays``).

    With ``cone_deg`` 0 it is a single ray along its axis. Otherwise it stands for a proximity
    sensor whose detection volume is a cone ``cone_deg`` wide: the floor's plane cuts it into
    a fan, cast as ``CONE_RAYS`` rays from edge to edge (``ray_angles_rad``), and the sensor
    reads the nearest hit of any of them. A hit counts only where the ray meets the surface
    within ``incidence_limit_deg`` of its normal (CoppeliaSim's "limited angle detection";
    90 is no limit): an ultrasonic echo off a surface seen too obliquely does not come back.
    """

    name: str  # channel name, 1-based as CoppeliaSim's legacy API: sonar1..sonar16
    x_m: float
    y_m: float
    angle_rad: float
    range_m: float
    cone_deg: float = 0.0  # full opening angle of the detection cone; 0: a single ray
    incidence_limit_deg: float = 90.0  # widest angle between a ray and the normal of what it hits

    def ray_angles_rad(self) -> tuple[float, ...]:
        """The directions of its rays in the robot frame, from the cone's right edge to its left."""
        if self.cone_deg <= 0.0:
            return (self.angle_rad,)
        half = math.radians(self.cone_deg) / 2.0
        step = 2.0 * half / (CONE_RAYS - 1)
        return tuple(self.angle_rad - half + k * step for k in range(CONE_RAYS))


@dataclass(frozen=True)
class Lidar:
    """A 2D scanning range finder: ``beams`` rays in the floor's plane, fanned over ``fov_deg``.

    It sits ``x_m`` ahead of the robot's origin. Beam k (channel ``lidar{k+1}``, counted
    from 1 as the sonars are) points at ``-fov_deg / 2 + k * step`` degrees, counter-clockwise
    as every angle here: the first beam is the rightmost, as ROS's ``angle_min`` and
    CoppeliaSim's 2D laser scanners order a scan. A full circle (360 degrees) has
    ``step = 360 / beams``, so no direction is read twice and beam ``beams // 2 + 1`` looks
    straight ahead; a narrower fan has both ends, ``step = fov_deg / (beams - 1)``. A beam
    reads the distance to the nearest thing it meets in metres, ``inf`` beyond ``range_m``.
    ``noise_std_m`` is the Gaussian noise the run adds to every echo (``labsim.runtime.noise``).
    """

    beams: int
    fov_deg: float
    range_m: float
    noise_std_m: float = 0.0
    x_m: float = 0.0

    def angles_rad(self) -> tuple[float, ...]:
        full = self.fov_deg >= 360.0
        step = self.fov_deg / (self.beams if full or self.beams == 1 else self.beams - 1)
        start = 0.0 if self.beams == 1 and not full else -self.fov_deg / 2.0
        return tuple(math.radians(start + k * step) for k in range(self.beams))

    def rays(self) -> tuple[Sonar, ...]:
        """The beams as single rays, the form every backend casts: ``lidar1`` .. ``lidarN``."""
        return tuple(Sonar(f"lidar{k + 1}", self.x_m, 0.0, a, self.range_m)
                     for k, a in enumerate(self.angles_rad()))


def is_lidar_beam(channel: str) -> bool:
    """Whether a channel is a lidar's beam (``lidar7``): a trace leaves them out, as a group."""
    return channel.startswith("lidar") and channel[5:].isdigit()


@dataclass(frozen=True)
class Bumper:
    """A contact switch on the chassis: True while something touches the chassis near it.

    Modelled as a small disc of radius ``reach_m`` centred on the chassis edge at
    (``x_m``, ``y_m``): the switch is pressed while a wall, block or another robot comes into
    the disc. A real bumper closes at a few millimetres of travel; ``reach_m`` stands for that
    travel plus the contact slop the physics allows.
    """

    name: str  # channel name: bump_front_left, bump_front_right, bump_back_left, bump_back_right
    x_m: float
    y_m: float
    reach_m: float = 0.01


@dataclass(frozen=True)
class GroundSensor:
    """A downward-looking reflectance sensor: the brightness of the floor under (``x_m``, ``y_m``).

    Reads 0 on black and 1 on white: the floor texture's luminance (ITU-R BT.601 weights,
    0.299 R + 0.587 G + 0.114 B, over 255) at the texture pixel under the point, the floor
    colour off the texture. Real IR ground sensors read a spot a few millimetres wide; one
    texture pixel (1 cm at the default 100 px/m) stands for it.
    """

    name: str  # channel name: ground1 .. groundN, left to right
    x_m: float
    y_m: float


@dataclass(frozen=True)
class Camera:
    """A forward-looking vision sensor on a robot, seeing the world's ground and the robots,
    walls and blocks standing on it.

    The image is RGB, ``height_px`` rows by ``width_px`` columns, in CoppeliaSim's row order:
    row 0 is the BOTTOM row of the picture (the near edge of the floor), column 0 the left.
    It is the array ``sim.getVisionSensorImg`` hands a script, so a behaviour and a script
    written for CoppeliaSim read the same numbers; whatever shows an image to a person turns
    it upright with ``upright`` (docs/decisions.md §9). The camera sits ``x_m`` ahead of the
    robot's origin, ``height_m`` above the floor, looking forward and down by ``pitch_deg``, and
    turned about its viewing axis by ``roll_deg``: positive turns the picture's top edge
    towards the robot's right, as seen from behind the camera (at -90 the rows run across the
    way ahead, row 0 on the right).
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
    lidars: tuple[Lidar, ...] = ()  # at most one; a behaviour file adds it (``lidar:``)
    bumpers: tuple[Bumper, ...] = ()
    ground_sensors: tuple[GroundSensor, ...] = ()
    # What other robots' cameras see of it: its footprint raised to height_m, in rgb (0..255).
    height_m: float = 0.2
    rgb: tuple[int, int, int] = (128, 128, 128)

    def rays(self) -> tuple[Sonar, ...]:
        """Every single ray the robot casts: its sonars (or IR sensors), then its lidar's beams."""
        return self.sonars + tuple(ray for lidar in self.lidars for ray in lidar.rays())

    def channels(self) -> dict[str, Kind]:
        """Every channel a behaviour may read from a robot of this model, in a stable order."""
        out: dict[str, Kind] = {s.name: Kind.DISTANCE for s in self.rays()}
        out.update({c.name: Kind.IMAGE for c in self.cameras})
        out.update({b.name: Kind.CONTACT for b in self.bumpers})
        out.update({g.name: Kind.REFLECTANCE for g in self.ground_sensors})
        out.update(POSE_CHANNELS)
        out["forward_speed"] = Kind.NUMBER  # m/s along the heading
        out["collided"] = Kind.BOOL
        return out


# Every robot reports its pose; the runtime also writes it to the trace.
POSE_CHANNELS: dict[str, Kind] = {"x": Kind.NUMBER, "y": Kind.NUMBER, "heading": Kind.NUMBER}


# --- Pioneer P3DX ---------------------------------------------------------------------------
# Sources, in order of trust (see ../shared/reference/coppeliasim-zmq-protocol.md, section 6):
# * Sonar poses and angles: course code reproducing CoppeliaSim's model (`robot_p3dx.py`,
#   SENSORS list); the angles match the real robot's sonar ring (90, 50, 30, 10, -10, ...),
#   and the sensors' own poses in the stock model (read as the volume below) agree within
#   0.4 mm; they sit 0.068 m above the model's base.
# * Wheel radius 0.0975 m (wheel diameter 195 mm): the same course code and the Pioneer 3
#   datasheet agree.
# * Axle length 0.331 m: uncertain, third-party figures range 0.311..0.381; 0.331 is the
#   half-axle 0.1655 seen in code written against CoppeliaSim's model.
# * Sonar volume, read from the stock model itself as CoppeliaSim saved it inside two public
#   scenes (docs/coppeliasim.md, "The Pioneer's ultrasonic sensors", says how): each of the 16
#   `Pioneer_p3dx_ultrasonicSensor`s is a cone-type proximity sensor (sensor subtype 33),
#   offset 0, range 1.0 m beyond a 5 mm close radius, opening angle 30 degrees, closest-point
#   detection, limited angle detection on at 45 degrees, detecting "ultrasonic"-detectable
#   objects. labsim keeps range 1.0 m (the volume's far cap lies at 1.005 m from the sensor's
#   point, 5 mm labsim leaves out) and casts the cone's cut by the floor's plane: a fan of
#   30 degrees (CONE_RAYS rays).
# * Max wheel speed 12.3 rad/s: the real P3DX's 1.2 m/s top speed / 0.0975 m. CoppeliaSim's
#   model sets no joint velocity limit that could be confirmed, so this is the real robot's.
# * Mass 9 kg: the Pioneer 3 datasheet (robot without batteries).
# * Footprint: the chassis outline through the sonar mounts (which sit on its edge) plus the
#   wheels, 0.42 m long and 0.38 m wide (datasheet: 455 x 381 mm including the bumpers).
# * Bumpers: the datasheet's optional front and rear bumper rings, as four switches, one per
#   corner of the outline (at the outer sonar mounts of each quarter), closing within 2 cm.
#   labsim's own simplification: the real rings have five segments each.
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
        Sonar(f"sonar{i + 1}", x, y, math.radians(a), 1.0, cone_deg=30.0, incidence_limit_deg=45.0)
        for i, (x, y, a) in enumerate(_P3DX_SONARS)
    ),
    bumpers=(
        Bumper("bump_front_left", 0.1909, 0.0831, 0.02), Bumper("bump_front_right", 0.1909, -0.0831, 0.02),
        Bumper("bump_back_left", -0.1943, 0.0785, 0.02), Bumper("bump_back_right", -0.1943, -0.0785, 0.02),
    ),
    height_m=0.237,  # Pioneer 3 datasheet: 237 mm body height
    rgb=(200, 30, 30),
)


# --- e-puck -----------------------------------------------------------------------------------
# Sources: the e-puck's published specifications (e-puck.org, GCtronic's e-puck wiki), Webots'
# e-puck model and its documentation ("GCtronic's e-puck", sensor orientation table), and the
# stock script of CoppeliaSim's e-puck model (models/robots/mobile/e-puck.ttm).
# * Body: a cylinder 70 mm across and 50 mm high (e-puck.org: "diameter 70 mm, height 50 mm");
#   the footprint is a 16-gon through that circle.
# * Wheel radius 0.0205 m (wheel diameter 41 mm) and axle 0.052 m (distance between the wheels'
#   contact points): Webots' documentation of its e-puck ("wheel radius 20.5 mm, distance
#   between wheels 52 mm"), which the e-puck.org figures (41 mm wheels, 53 mm apart) round.
# * Max wheel speed 6.24 rad/s: CoppeliaSim's stock e-puck script (maxVel = 6.24); Webots uses
#   6.28 (one turn a second), the real robot's steppers about 1000 steps/s of 1000 a turn.
# * Mass 0.16 kg: uncertain; e-puck.org says 150 g for the robot, GCtronic 200 g with battery
#   and extension boards. Only collisions feel it.
# * 8 IR proximity sensors, as CoppeliaSim numbers them (ePuck_proxSensor1..8: 1 is the left
#   side, 3 and 4 the front pair, 6 the right side, 7 and 8 the back pair, as a script written
#   for that model maps its pins). Their directions are Webots' table (ps0..ps7 at 0.30, 0.80,
#   1.57, 2.64 rad to the right of ahead, and mirrored to the left), which puts the front pair
#   17 degrees either side of ahead: prox1 = ps5 (+90), prox2 = ps6 (+46), prox3 = ps7 (+17),
#   prox4 = ps0 (-17), prox5 = ps1 (-46), prox6 = ps2 (-90), prox7 = ps3 (-151), prox8 = ps4
#   (+151). Mounts on the body's edge (radius 0.035 m) along those directions. Range 0.07 m:
#   uncertain, the last point of Webots' lookup table (about 7 cm, where the reflected light
#   is lost in the ambient); a real IR sensor reads light, not distance: labsim gives the
#   distance, as CoppeliaSim's proximity sensors do.
# * Camera: a VGA colour camera on the real robot (640 x 480); Webots' model reads it as 52 x 39
#   px with a field of view of 0.84 rad (48 degrees), and labsim does the same, from 3 cm up at
#   the front edge (3.5 cm ahead), looking level as the stock models' camera does. The
#   camera's height is uncertain (the lens sits on the board's front, about 3 cm up).
# * 3 ground sensors (GCtronic's ground sensors extension, Webots' E-puckGroundSensors: gs0,
#   gs1, gs2 left to right, about 1 cm apart at the front edge): x = 0.03 m, y = +0.01, 0, -0.01.
#   The spacing and the 3 cm are uncertain: read off pictures of the extension, not checked
#   against Webots' proto.
#   CoppeliaSim's stock e-puck has no ground sensors: through labsim serve they are named
#   ePuck_groundSensor1..3 (labsim's names, not CoppeliaSim's).
_EPUCK_RADIUS_M = 0.035
_EPUCK_PROX = ((1, 90.0), (2, 46.0), (3, 17.0), (4, -17.0), (5, -46.0), (6, -90.0), (7, -151.0), (8, 151.0))

EPUCK = RobotModel(
    name="epuck",
    description="e-puck: differential drive, 8 IR proximity sensors, camera, 3 ground sensors",
    wheel_radius_m=0.0205,
    axle_length_m=0.052,
    max_wheel_speed_rad_s=6.24,
    mass_kg=0.16,
    footprint=tuple((_EPUCK_RADIUS_M * math.cos(2 * math.pi * k / 16), _EPUCK_RADIUS_M * math.sin(2 * math.pi * k / 16))
                    for k in range(16)),
    sonars=tuple(
        Sonar(f"prox{i}", _EPUCK_RADIUS_M * math.cos(math.radians(a)), _EPUCK_RADIUS_M * math.sin(math.radians(a)),
              math.radians(a), 0.07)
        for i, a in _EPUCK_PROX
    ),
    cameras=(Camera("camera", 52, 39, 48.0, 0.03, 0.0, 0.035),),
    ground_sensors=(GroundSensor("ground1", 0.03, 0.01), GroundSensor("ground2", 0.03, 0.0),
                    GroundSensor("ground3", 0.03, -0.01)),
    height_m=0.05,
)

MODELS: dict[str, RobotModel] = {m.name: m for m in (PIONEER_P3DX, EPUCK)}
