"""labsim.runtime.pictures.plot: traces drawn to scale over their world, checked pixel by pixel."""
from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np
import pytest
from helpers import straight, write_trace

from labsim.backends.scene.world import builtin_worlds
from labsim.runtime.pictures.paint import robot_colour
from labsim.runtime.pictures.plot import plot_trace, render_figure, robot_paths
from labsim.runtime.trace import TraceFormatError, read_trace, trace_world


def pixel(img: np.ndarray, fig, x: float, y: float) -> np.ndarray:
    u, v = fig.to_px(x, y)
    return img[round(v), round(u)].astype(int)


def test_png_to_scale_with_walls_and_path(tmp_path: Path) -> None:
    trace = write_trace(tmp_path / "run.csv", {"pioneer": straight(-5.0, -5.0, -1.0, -5.0)})
    out = plot_trace(trace, tmp_path / "run.png", width_px=800)
    assert out == tmp_path / "run.png" and out.is_file()
    img = cv2.imread(str(out))
    assert img.shape[1] == 800
    fig = render_figure(read_trace(trace), width_px=800)
    assert fig.image.shape == img.shape
    # same metres per pixel both ways: a 4 m square is as tall as it is wide
    (u0, v0), (u1, v1) = fig.to_px(0, 0), fig.to_px(4, 4)
    assert abs((u1 - u0) - (v0 - v1)) < 1e-9 and u1 > u0 and v1 < v0
    # the south wall (y = -7.5) and the inner wall from the west (y = 1.5) are dark
    for x, y in [(0.0, -7.5), (-3.0, 1.5), (3.0, -5.0)]:
        assert pixel(img, fig, x, y).max() < 100, (x, y)
    # the path, away from its start and end markers, is the robot's colour
    colour = np.array(robot_colour(0))
    for x in (-4.0, -3.0, -2.3):
        assert np.abs(pixel(img, fig, x, -5.0) - colour).max() < 40, x
    # open floor is light
    assert pixel(img, fig, 4.5, 2.5).min() > 200


def test_collision_marked_red_once_per_contact(tmp_path: Path) -> None:
    path = straight(-2.0, -3.0, 2.0, -3.0, n=40)
    # in contact for five ticks from the 20th: one collision, at its first tick
    for i in range(20, 25):
        x, y, h, _, _ = path[i]
        path[i] = (x, y, h, 1, "bumps" if i == 20 else "")
    trace = write_trace(tmp_path / "hit.csv", {"pioneer": path})
    paths = robot_paths(read_trace(trace))
    assert len(paths[0].collisions) == 1
    cx, cy = paths[0].collisions[0]
    assert (cx, cy) == pytest.approx(path[20][:2])
    assert len(paths[0].events["bumps"]) == 1

    out = plot_trace(trace, tmp_path / "hit.png")
    img = cv2.imread(str(out)).astype(int)
    fig = render_figure(read_trace(trace))
    u, v = (round(c) for c in fig.to_px(cx, cy))
    near = img[v - 8:v + 9, u - 8:u + 9]
    b, g, r = near[..., 0], near[..., 1], near[..., 2]
    assert np.count_nonzero((r > 170) & (g < 90) & (b < 90)) >= 15
    # and no red at a point of the path without a collision
    u, v = (round(c) for c in fig.to_px(-1.0, -3.0))
    far = img[v - 5:v + 6, u - 5:u + 6]
    assert np.count_nonzero((far[..., 2] > 170) & (far[..., 1] < 90) & (far[..., 0] < 90)) == 0


def test_robots_get_distinct_colours(tmp_path: Path) -> None:
    trace = write_trace(tmp_path / "two.csv", {"a": straight(-5, -5, -1, -5), "b": straight(-5, 4, -1, 4)})
    paths = robot_paths(read_trace(trace))
    assert [p.name for p in paths] == ["a", "b"]
    assert paths[0].colour != paths[1].colour
    out = plot_trace(trace, tmp_path / "two.png")
    img = cv2.imread(str(out))
    fig = render_figure(read_trace(trace))
    assert np.abs(pixel(img, fig, -3, -5) - robot_colour(0)).max() < 40
    assert np.abs(pixel(img, fig, -3, 4) - robot_colour(1)).max() < 40


def test_builtin_world_when_the_recorded_file_is_gone(tmp_path: Path) -> None:
    trace = write_trace(tmp_path / "moved.csv", {"pioneer": straight(-5, -5, -1, -5)},
                        world_file="/no/such/dir/walls_lab4.yaml")
    world, note = trace_world(read_trace(trace))
    assert world is not None and world.name == "walls_lab4" and note == ""


def test_unknown_world_is_drawn_without_walls(tmp_path: Path) -> None:
    trace = write_trace(tmp_path / "lost.csv", {"pioneer": straight(10, 10, 14, 12)},
                        world="atrium", world_file="/no/such/atrium.yaml")
    world, note = trace_world(read_trace(trace))
    assert world is None and "atrium" in note and "without walls" in note
    out = plot_trace(trace, tmp_path / "lost.png", width_px=600)
    img = cv2.imread(str(out))
    assert img.shape[1] == 600
    fig = render_figure(read_trace(trace), width_px=600)
    # the view follows the path, which the walls_lab4 room would not contain
    assert np.abs(pixel(img, fig, 12, 11) - robot_colour(0)).max() < 40


@pytest.mark.parametrize("name", ["plot.xyz", "plot", "missing_dir/plot.png"])
def test_unwritable_output_is_a_value_error(tmp_path: Path, name: str) -> None:
    trace = write_trace(tmp_path / "run.csv", {"pioneer": straight(-5, -5, -1, -5)})
    with pytest.raises(ValueError, match="plot"):
        plot_trace(trace, tmp_path / name)
    assert not (tmp_path / name).exists()


def test_output_that_is_a_directory_is_a_value_error(tmp_path: Path) -> None:
    trace = write_trace(tmp_path / "run.csv", {"pioneer": straight(-5, -5, -1, -5)})
    (tmp_path / "out.png").mkdir()
    with pytest.raises(ValueError, match="directory"):
        plot_trace(trace, tmp_path / "out.png")


def test_too_narrow_is_a_value_error(tmp_path: Path) -> None:
    trace = write_trace(tmp_path / "run.csv", {"pioneer": straight(-5, -5, -1, -5)})
    with pytest.raises(ValueError, match="width"):
        plot_trace(trace, tmp_path / "run.png", width_px=50)


def test_not_a_trace(tmp_path: Path) -> None:
    (tmp_path / "junk.csv").write_text("a,b\n1,2\n")
    with pytest.raises(TraceFormatError):
        plot_trace(tmp_path / "junk.csv", tmp_path / "junk.png")


def test_a_long_trace_plots_every_collision(tmp_path: Path) -> None:
    # how long it takes is benchmarks/bench_plot.py's business
    n = 30_000
    t = np.arange(n) * 0.01
    poses = [(5 * math.cos(a), 5 * math.sin(a) * math.cos(3 * a), a + math.pi / 2,
              int(k % 1000 in (1, 2)), "bumps" if k % 1000 == 1 else "")
             for k, a in enumerate(t)]
    trace = write_trace(tmp_path / "long.csv", {"pioneer": poses})
    out = plot_trace(trace, tmp_path / "long.png")
    assert out.is_file()
    assert len(robot_paths(read_trace(trace))[0].collisions) == n // 1000


def test_ground_is_drawn_under_the_paths(tmp_path: Path) -> None:
    world_file = builtin_worlds()["road_compact"]
    trace = write_trace(tmp_path / "road.csv", {"pioneer": straight(-5.0, -15.0, 0.0, -15.0)},
                        world="road_compact", world_file=str(world_file))
    out = plot_trace(trace, tmp_path / "road.png", width_px=900)
    img = cv2.imread(str(out))
    fig = render_figure(read_trace(trace), width_px=900)
    # the road is dark (the left straight at x = -17, the top one at y = 20, the right one at
    # x = 20), the floor its colour (BGR of [205, 205, 200]) inside the loop and outside it
    for x, y in [(-17.0, 2.3), (0.3, 20.0), (20.0, 0.4), (5.3, -15.0)]:
        assert pixel(img, fig, x, y).max() < 60, (x, y)
    for x, y in [(1.3, 0.4), (-20.3, -17.6), (10.2, 5.4)]:  # off the 1 m grid lines
        assert np.abs(pixel(img, fig, x, y) - (200, 205, 205)).max() <= 3, (x, y)
    # to scale: 2 m wide across the left straight
    row = round(fig.to_px(0.0, 2.3)[1])
    u0, u1 = round(fig.to_px(-19.0, 0.0)[0]), round(fig.to_px(-15.0, 0.0)[0])
    dark_px = int((img[row, u0:u1].max(axis=1) < 110).sum())
    assert dark_px * fig.m_per_px == pytest.approx(2.0, abs=2.5 * fig.m_per_px)
    # the path is drawn over the road, and the walls still on top of the floor
    assert np.abs(pixel(img, fig, -2.0, -15.0) - robot_colour(0)).max() < 40
    assert pixel(img, fig, 0.3, -20.0).max() < 100  # the south wall
