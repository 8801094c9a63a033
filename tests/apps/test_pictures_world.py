"""labsim plot's pictures against what they show: chart pixels at known times and values, the
road panel and the camera strip against the run's own channels, and the road and wall labs'
animations against their worlds."""
from __future__ import annotations

import math
import re
from pathlib import Path

import cv2
import imageio.v2 as imageio
import numpy as np
import pytest
from helpers import BEHAVIOURS

from labsim.backends.scene.world import World, builtin_worlds
from labsim.dsl.library import images
from labsim.runtime.cli.main import main
from labsim.runtime.pictures.camera_strip import shots
from labsim.runtime.pictures.paint import PAPER, WALL, Painter, robot_colour
from labsim.runtime.pictures.plot import render_figure, robot_paths
from labsim.runtime.pictures.road_panel import draw_road_panel, road_curves
from labsim.runtime.pictures.signals import chart_figure
from labsim.runtime.trace import FORMAT, Trace, TraceWriter, read_trace, trace_world

ROAD = BEHAVIOURS / "road_follow.golden.csv"
WALL_LAB = BEHAVIOURS / "wall_follow.golden.csv"


def cli(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str, str]:
    code = main(list(args))
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    return code, out, err


def world_of(trace: Trace) -> World:
    world, note = trace_world(trace)
    assert world is not None, note
    return world


def near(img: np.ndarray, u: float, v: float, colour: tuple[int, int, int], r: int = 2, tol: int = 40) -> bool:
    """Whether a pixel within r of (u, v) has this colour (same channel order as img)."""
    patch = img[round(v) - r:round(v) + r + 1, round(u) - r:round(u) + r + 1, :3].astype(int)
    return bool((np.abs(patch - np.array(colour)).max(axis=2) < tol).any())


# -- a chart's pixels --------------------------------------------------------------------------

def test_chart_pixels_sit_at_their_time_and_value(tmp_path: Path) -> None:
    # one robot whose signal v is 0 until 1.5 s, then 2: a step the PNG must show where it is
    trace_path = tmp_path / "step.csv"
    header = {"format": FORMAT, "labsim": "0.1.0", "name": "step", "dt": 0.05, "robots": {"r": "pioneer_p3dx"}}
    w = TraceWriter(trace_path, header, ["tick", "time", "robot", "x", "y", "heading", "state", "v"])
    try:
        for k in range(61):
            t = round(k * 0.05, 9)
            w.write([k, t, "r", 0.0, 0.0, 0.0, "go", 0.0 if t < 1.5 else 2.0])
    finally:
        w.close()
    trace = read_trace(trace_path)
    fig = chart_figure(trace, ["v"], width_px=800)
    ax = fig.axes[-1]
    out = tmp_path / "step.png"
    fig.savefig(out, dpi=fig.dpi)
    img = cv2.imread(str(out))
    assert img.shape[1] == 800
    height = img.shape[0]

    def at(t: float, v: float) -> tuple[float, float]:
        u, y = ax.transData.transform((t, v))  # display pixels, origin at the bottom left
        return u, height - y

    line = robot_colour(0)  # BGR, as the map draws the robot
    for t, v in ((0.5, 0.0), (1.0, 0.0), (2.0, 2.0), (2.8, 2.0)):
        assert near(img, *at(t, v), line), (t, v)
    for t, v in ((0.5, 2.0), (2.0, 0.0), (1.0, 1.0)):
        assert not near(img, *at(t, v), line), (t, v)


# -- the road panel ----------------------------------------------------------------------------

def test_road_panel_offsets_are_the_runs_own_road_offset() -> None:
    trace = read_trace(ROAD)
    paths = robot_paths(trace)
    found = road_curves(world_of(trace), [(p.name, p.colour, p.xy) for p in paths])
    assert found is not None
    curves, half_w = found
    assert half_w == pytest.approx(1.5)
    ri, oi = trace.columns.index("robot"), trace.columns.index("road_offset")
    for c in curves:
        recorded = np.array([float(r[oi]) for r in trace.rows if r[ri] == c.name])
        assert np.abs(c.offset_m - recorded).max() < 1e-3, c.name  # the trace rounds to 6 digits
        # 30 s at about 0.49 m/s, forward along the road: about 14.6 m each
        assert c.along_m[0] == 0 and 14 < c.along_m[-1] < 15.5, c.name


def test_road_panel_draws_each_robot_where_its_offset_is() -> None:
    trace = read_trace(ROAD)
    paths = robot_paths(trace)
    P = Painter(1000)
    img = np.full((400, 1000, 3), PAPER, np.uint8)
    box = (60, 20, 800, 300)
    robots = [(p.name, p.colour, p.xy) for p in paths]
    ext = draw_road_panel(img, P, world_of(trace), robots, box)
    assert ext is not None
    a_lo, a_hi, o_lo, o_hi = ext
    found = road_curves(world_of(trace), robots)
    assert found is not None
    y0, y1 = box[1] + round(30 * P.s), box[1] + box[3] - round(40 * P.s)
    for c in found[0]:
        k = len(c.along_m) * 3 // 4
        u = box[0] + (c.along_m[k] - a_lo) / (a_hi - a_lo) * box[2]
        v = y0 + (o_hi - c.offset_m[k]) / (o_hi - o_lo) * (y1 - y0)
        assert near(img, u, v, c.colour, r=3), c.name


def test_a_world_without_a_road_has_no_panel() -> None:
    trace = read_trace(WALL_LAB)
    assert road_curves(world_of(trace), [("pioneer", (0, 0, 0), np.zeros((2, 2)))]) is None


# -- the camera strip --------------------------------------------------------------------------

def test_camera_frames_are_what_the_robot_saw() -> None:
    # the behaviour's cy is the row of the centroid of its thresholded camera image (the floor
    # white, not inverted): the re-rendered frames give the same centroid at the same ticks,
    # once turned back from upright (the strip) to the camera's own rows, bottom first
    trace = read_trace(ROAD)
    camera, frames = shots(trace, "pioneer[3]", world_of(trace))
    assert (camera.width_px, camera.height_px, camera.fov_deg) == (128, 128, 40)
    assert len(frames) == 5 and frames[0].t_s == 0 and frames[-1].t_s == pytest.approx(29.95)
    ti, ri, ci = (trace.columns.index(c) for c in ("time", "robot", "cy"))
    for shot in frames:
        row = next(r for r in trace.rows if r[ri] == "pioneer[3]" and float(r[ti]) == shot.t_s)
        lane = images.threshold(images.gray(cv2.cvtColor(shot.image[::-1], cv2.COLOR_BGR2RGB)), 20)
        assert images.centroid(lane)[1] == pytest.approx(float(row[ci]), abs=1e-3), shot.t_s


def test_camera_frames_show_the_robot_ahead_as_the_run_saw_it() -> None:
    # the road lab's cameras see the other robots (pioneer[1], red, 12.5 m ahead of pioneer[0]):
    # the strip re-renders them, so every robot's frames give the centroid the run traced
    trace = read_trace(ROAD)
    ti, ri, ci = (trace.columns.index(c) for c in ("time", "robot", "cy"))
    for robot in ("pioneer[0]", "pioneer[1]", "pioneer[2]"):
        _, frames = shots(trace, robot, world_of(trace))
        for shot in frames:
            row = next(r for r in trace.rows if r[ri] == robot and float(r[ti]) == shot.t_s)
            lane = images.threshold(images.gray(cv2.cvtColor(shot.image[::-1], cv2.COLOR_BGR2RGB)), 20)
            # the trace's poses have 6 digits: a robot's edge in the picture may move a pixel
            assert images.centroid(lane)[1] == pytest.approx(float(row[ci]), abs=0.02), (robot, shot.t_s)
    _, frames = shots(trace, "pioneer[0]", world_of(trace))
    for shot in frames:  # BGR: the Pioneer's red body, far ahead, a few dozen pixels
        b, g, r = (shot.image[..., k].astype(int) for k in range(3))
        assert 10 <= ((r > 120) & (g < 60) & (b < 60)).sum() <= 200, shot.t_s


def test_camera_strip_under_the_map(capsys, tmp_path: Path) -> None:
    plain, strip = tmp_path / "map.png", tmp_path / "cam.png"
    assert cli(capsys, "plot", str(ROAD), "-o", str(plain), "--to", "3")[0] == 0
    code, printed, _ = cli(capsys, "plot", str(ROAD), "--camera", "pioneer[0]", "-o", str(strip), "--to", "3")
    assert code == 0 and f"wrote {strip}" in printed
    a, b = cv2.imread(str(plain)), cv2.imread(str(strip))
    assert b.shape[1] == a.shape[1] and b.shape[0] > a.shape[0] + 150
    # the frames look down the road: dark road pixels in the bottom middle of the first frame
    bottom = b[a.shape[0]:]
    assert (bottom.max(axis=2) < 40).sum() > 1000


@pytest.mark.parametrize(("trace", "args", "message"), [
    (ROAD, ["--camera", "pioneer[9]"], "no robot of that name in the trace (robots: pioneer[0], pioneer[1]"),
    (WALL_LAB, ["--camera", "pioneer"], "the behaviour gives this robot no camera (no robot in it has one)"),
    (ROAD, ["--camera", "pioneer[0]", "--signals", "cx"], "--camera adds camera frames under the map"),
])
def test_camera_mistakes_are_exit_2(capsys, tmp_path: Path, trace: Path, args: list[str], message: str) -> None:
    code, _, err = cli(capsys, "plot", str(trace), *args, "-o", str(tmp_path / "x.png"), "--to", "1")
    assert code == 2 and message in err


def test_camera_without_the_behaviour_file_is_exit_2(capsys, tmp_path: Path) -> None:
    moved = tmp_path / "road.csv"
    # an edited copy of the lab (another hash: not the lab labsim ships), since moved away
    header, rest = ROAD.read_text().split("\n", 1)
    header = header.replace("behaviours/road_follow.yaml", "gone/road_follow.yaml", 1)
    moved.write_text(re.sub(r'"sha256": "[0-9a-f]+"', '"sha256": "' + "0" * 64 + '"', header) + "\n" + rest)
    code, _, err = cli(capsys, "plot", str(moved), "--camera", "pioneer[0]", "-o", str(tmp_path / "x.png"))
    assert code == 2 and "--camera needs the behaviour file that made the trace, for the camera's mount; the " \
                         "trace names gone/road_follow.yaml, which is not there; pass --behaviour PATH" in err


# -- the labs' animations against their worlds ---------------------------------------------------

def test_road_animation_starts_each_robot_on_its_spawn(capsys, tmp_path: Path) -> None:
    trace = read_trace(ROAD)
    world = world_of(trace)
    out = tmp_path / "road.gif"
    code, _, _ = cli(capsys, "plot", str(ROAD), "-o", str(out), "--to", "1", "--fps", "2", "--width", "800")
    assert code == 0
    first = imageio.mimread(out)[0]
    fig = render_figure(trace, width_px=800, backdrop=True)
    assert len(world.spawns) >= 5
    for k, spawn in enumerate(world.spawns[:5]):
        # the world's spawn poses, in order, are where the robots start, and drawn there
        row = trace.rows[k]
        assert (float(row[3]), float(row[4])) == pytest.approx((spawn.x_m, spawn.y_m), abs=1e-6)
        u, v = fig.to_px(spawn.x_m, spawn.y_m)
        assert near(first, u, v, robot_colour(k)[::-1], r=3), k  # the GIF is RGB


def test_wall_animation_draws_the_walls_and_the_start(capsys, tmp_path: Path) -> None:
    trace = read_trace(WALL_LAB)
    world = world_of(trace)
    out = tmp_path / "wall.gif"
    code, _, _ = cli(capsys, "plot", str(WALL_LAB), "-o", str(out), "--to", "2", "--fps", "2", "--width", "800")
    assert code == 0
    first = imageio.mimread(out)[0]
    fig = render_figure(trace, width_px=800, backdrop=True)
    x, y, heading = (float(trace.rows[0][i]) for i in (3, 4, 5))
    assert world.clearance(x, y) > 0.2  # a random start, but in the room and clear of walls
    u, v = fig.to_px(x - 0.1 * math.cos(heading), y - 0.1 * math.sin(heading))  # behind the heading line
    assert near(first, u, v, robot_colour(0)[::-1], r=2)
    for wall in world.walls:  # every wall's middle is drawn in the wall colour
        u, v = fig.to_px((wall.a[0] + wall.b[0]) / 2, (wall.a[1] + wall.b[1]) / 2)
        assert near(first, u, v, WALL[::-1], r=1, tol=30), wall


def test_builtin_worlds_used_here_exist() -> None:
    assert {"road_loop", "walls_lab4"} <= set(builtin_worlds())
