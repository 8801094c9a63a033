"""Camera frames under the map: ``labsim plot TRACE --camera ROBOT -o run.png``.

A stage after the run, beside the still map of ``labsim.runtime.pictures.plot``. A trace records poses,
not images, so the frames are re-rendered: the camera's mount and resolution come from the
behaviour file the trace header names (compiled with ``labsim.dsl.compile``), the ground, walls
and blocks from the world the map draws, the other robots (their models from the same file) at
their poses of the same tick, and the image from the embedded backend's scene camera, the
renderer the run's cameras use, reached through the backend registry
(``labsim.backends.scene_camera``) like every simulator. A few times spread
over the robot's rows each give one frame, numbered; the same numbers mark the robot's pose at
those times on the map, so a frame can be matched to where the robot was.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass

import cv2
import numpy as np

from labsim.backends import BackendError, scene_camera
from labsim.backends.scene.ground import Ground
from labsim.backends.scene.models import Camera, RobotModel, upright
from labsim.backends.scene.world import World
from labsim.dsl.compile import compile_file
from labsim.foundation.diagnostics import Diagnostic, LabsimError
from labsim.runtime.pictures.map_frame import Figure
from labsim.runtime.pictures.paint import AA, FRAME, INK, MUTED, PAPER, Painter, darker
from labsim.runtime.pictures.trace_behaviour import behaviour_file, not_found
from labsim.runtime.trace import Trace

FRAMES = 5


@dataclass(frozen=True)
class Shot:
    """One frame of the strip: when, where the robot was, and what its camera saw (BGR, upright)."""

    t_s: float
    x_m: float
    y_m: float
    heading_rad: float
    image: np.ndarray


def _fail(where: str, message: str) -> LabsimError:
    return LabsimError([Diagnostic(where, message)])


def _names(trace: Trace) -> list[str]:
    return list(dict.fromkeys(trace.column("robot"))) if "robot" in trace.columns else []


def _program_models(trace: Trace) -> tuple[str, dict[str, RobotModel]]:
    """The behaviour file that made the trace, and its robot groups' models by group name."""
    path = behaviour_file(trace)
    if path is None:
        raise _fail(trace.path, f"--camera needs the behaviour file that made the trace, for the camera's mount; "
                                f"the trace {not_found(trace)}")
    program = compile_file(path)  # a file with mistakes is a LabsimError of its own, with positions
    return str(path), {g.name: g.model for g in program.robots if g.model is not None}


def _group(robot: str) -> str:
    return re.sub(r"\[\d+\]$", "", robot)


def _camera_and_models(trace: Trace, robot: str) -> tuple[Camera, dict[str, RobotModel]]:
    names = _names(trace)
    if robot not in names:
        raise _fail(trace.path, f"--camera {robot}: no robot of that name in the trace (robots: {', '.join(names)})")
    path, models = _program_models(trace)
    with_camera = [name for name, model in models.items() if model.cameras]
    model = models.get(_group(robot))
    if model is None or not model.cameras:
        have = f"robots with one: {', '.join(with_camera)}" if with_camera else "no robot in it has one"
        raise _fail(path, f"--camera {robot}: the behaviour gives this robot no camera ({have})")
    return model.cameras[0], models


def shots(trace: Trace, robot: str, world: World | None, frames: int = FRAMES) -> tuple[Camera, list[Shot]]:
    """The robot's camera and its frames at ``frames`` times spread from its first row to its
    last, each with the other robots where the trace has them at that time."""
    camera, models = _camera_and_models(trace, robot)
    for needed in ("time", "x", "y", "heading"):
        if needed not in trace.columns:
            raise _fail(trace.path, f"--camera needs the trace's '{needed}' column, which it does not have")
    names = [n for n in _names(trace) if _group(n) in models]
    poses = _poses(trace)
    rows = [(t, *pose) for t, who, pose in poses if who == robot]
    if not rows:
        raise _fail(trace.path, f"--camera {robot}: the trace has no pose of this robot")
    at_time: dict[float, dict[str, tuple[float, float, float]]] = {}
    for when, who, pose in poses:
        at_time.setdefault(when, {})[who] = pose
    ground = world.ground if world is not None and isinstance(world.ground, Ground) else Ground()
    try:
        render = scene_camera(ground, world, [models[_group(n)] for n in names])
    except BackendError as e:
        raise _fail(trace.path, str(e)) from None
    me = names.index(robot)
    picks = sorted({round(k * (len(rows) - 1) / max(frames - 1, 1)) for k in range(frames)})
    out = []
    for i in picks:
        t, x, y, h = rows[i]
        others = [at_time[t].get(n) for n in names]
        # rendered bottom row first, as CoppeliaSim sends it; the strip shows it upright
        image = render(x, y, h, camera, me, others)
        out.append(Shot(t, x, y, h, cv2.cvtColor(np.ascontiguousarray(upright(image)), cv2.COLOR_RGB2BGR)))
    return camera, out


def _poses(trace: Trace) -> list[tuple[float, str, tuple[float, float, float]]]:
    """(time, robot, (x, y, heading)) of every row with a finite pose, in the trace's order."""
    col = {c: trace.columns.index(c) for c in ("time", "x", "y", "heading", "robot")}
    out = []
    for r in trace.rows:
        try:
            t = float(r[col["time"]])
            pose = (float(r[col["x"]]), float(r[col["y"]]), float(r[col["heading"]]))
        except ValueError:
            continue
        if math.isfinite(t) and all(math.isfinite(v) for v in pose):
            out.append((t, r[col["robot"]], pose))
    return out


def draw_strip(width_px: int, robot: str, camera: Camera, frames: list[Shot],
               colour: tuple[int, int, int]) -> np.ndarray:
    """The strip as an image of its own, ``width_px`` wide: a caption, then the frames in a row."""
    P = Painter(width_px)
    s, pad = P.s, P.pad
    gap = round(12 * s)
    n = max(len(frames), 1)
    tile_w = min((width_px - 2 * pad - (n - 1) * gap) // n, 4 * camera.width_px)
    tile_h = round(tile_w * camera.height_px / camera.width_px)
    head_h, foot_h = round(34 * s), round(30 * s)
    img = np.full((head_h + tile_h + foot_h + pad, width_px, 3), PAPER, np.uint8)
    caption = (f"camera of {robot}: {camera.width_px} x {camera.height_px} px, {camera.fov_deg:g} deg wide, "
               f"{camera.height_m:g} m up, {camera.pitch_deg:g} deg down"
               + (f", rolled {camera.roll_deg:g} deg" if camera.roll_deg else "")
               + "; re-rendered from the trace's poses")
    P.put(img, caption, (pad, round(22 * s)), P.text, INK, max_w=width_px - 2 * pad)
    for k, shot in enumerate(frames):
        x = pad + k * (tile_w + gap)
        tile = cv2.resize(shot.image, (tile_w, tile_h), interpolation=cv2.INTER_AREA
                          if tile_w < camera.width_px else cv2.INTER_NEAREST)
        img[head_h:head_h + tile_h, x:x + tile_w] = tile
        cv2.rectangle(img, (x, head_h), (x + tile_w - 1, head_h + tile_h - 1), FRAME, P.lw)
        _badge(img, P, (x + round(14 * s), head_h + round(14 * s)), k + 1, colour)
        P.put(img, f"t = {shot.t_s:.1f} s", (x + tile_w / 2, head_h + tile_h + round(20 * s)), P.text, MUTED,
              align="center")
    return img


def mark_shots(fig: Figure, P: Painter, frames: list[Shot], colour: tuple[int, int, int]) -> None:
    """Number the robot's poses at the frames' times on the map, as the strip numbers its frames."""
    for k, shot in enumerate(frames):
        u, v = fig.to_px(shot.x_m, shot.y_m)
        # beside the path, not on it: the numbers sit to the robot's left
        off = 16 * P.s
        u -= off * math.sin(shot.heading_rad)
        v -= off * math.cos(shot.heading_rad)
        _badge(fig.image, P, (round(u), round(v)), k + 1, colour)


def _badge(img: np.ndarray, P: Painter, centre: tuple[int, int], number: int, colour: tuple[int, int, int]) -> None:
    r = round(10 * P.s)
    cv2.circle(img, centre, r, PAPER, -1, AA)
    cv2.circle(img, centre, r, darker(colour), max(1, round(1.5 * P.s)), AA)
    w, h = P.size(str(number), P.small)
    P.put(img, str(number), (centre[0] - w / 2, centre[1] + h / 2), P.small, INK)
