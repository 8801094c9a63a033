"""labsim plot's other pictures: signals charts, animations, the crane's pose, and bad input."""
from __future__ import annotations

import shutil
from pathlib import Path

import cv2
import imageio.v2 as imageio
import numpy as np
import pytest
from helpers import BEHAVIOURS, straight, write_trace

from labsim.backends.scene.world import builtin_worlds
from labsim.backends.scene.world_file import load_world
from labsim.foundation.diagnostics import Report
from labsim.runtime.cli.main import main
from labsim.runtime.pictures.animate import frame_times
from labsim.runtime.pictures.mechanism_pose import mechanism_poses
from labsim.runtime.pictures.paint import robot_colour
from labsim.runtime.pictures.plot import render_figure
from labsim.runtime.pictures.signals import default_signals
from labsim.runtime.trace import Trace, read_trace

CRANE = BEHAVIOURS / "crane.golden.csv"


def cli(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str, str]:
    code = main(list(args))
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    return code, out, err


def crane_window(tmp_path: Path, seconds: float) -> Path:
    """The crane's golden trace up to a time, beside a copy of its behaviour file."""
    shutil.copy(BEHAVIOURS / "crane.yaml", tmp_path / "crane.yaml")
    lines = CRANE.read_text().splitlines(keepends=True)
    keep = [ln for ln in lines[2:] if float(ln.split(",")[1]) <= seconds]
    out = tmp_path / "crane.csv"
    out.write_text("".join(lines[:2] + keep))
    return out


# -- signals ---------------------------------------------------------------------------------

@pytest.mark.parametrize("suffix", [".png", ".svg", ".pdf"])
def test_signals_chart_in_each_format(capsys, tmp_path: Path, suffix: str) -> None:
    out = tmp_path / f"signals{suffix}"
    code, printed, _ = cli(capsys, "plot", str(BEHAVIOURS / "road_follow.golden.csv"),
                           "--signals", "cy,angle,road_offset", "-o", str(out), "--width", "800")
    assert code == 0 and f"wrote {out}" in printed
    data = out.read_bytes()
    if suffix == ".png":
        img = cv2.imread(str(out))
        assert img.shape[1] == 800 and img.shape[0] > 600  # three panels
        # each of the five robots' lines is in the picture, in its map colour
        for k in range(5):
            near = np.abs(img.astype(int) - np.array(robot_colour(k))).max(axis=2) < 30
            assert near.sum() > 50, k
    elif suffix == ".svg":
        assert (b"<svg" in data[:500] and b"road_offset (m)" in data) or b"road_offset" in data
    else:
        assert data.startswith(b"%PDF")


def test_signals_default_to_what_the_metrics_read() -> None:
    assert default_signals(read_trace(CRANE)) == ["swing", "load_z", "tension", "slew"]
    assert "road_offset" in default_signals(read_trace(BEHAVIOURS / "road_follow.golden.csv"))


def test_an_svg_without_signals_charts_the_defaults(capsys, tmp_path: Path) -> None:
    out = tmp_path / "crane.svg"
    code, _, _ = cli(capsys, "plot", str(CRANE), "-o", str(out))
    assert code == 0 and b"tension (N)" in out.read_bytes()


def test_unknown_signal_lists_the_columns(capsys, tmp_path: Path) -> None:
    code, _, err = cli(capsys, "plot", str(CRANE), "--signals", "swing,sway", "-o", str(tmp_path / "s.png"))
    assert code == 2
    assert "no column 'sway'" in err and "swing" in err and "tension" in err


def test_unsupported_suffix_lists_the_supported_ones(capsys, tmp_path: Path) -> None:
    code, _, err = cli(capsys, "plot", str(CRANE), "-o", str(tmp_path / "run.avi"))
    assert code == 2 and ".gif" in err and ".mp4" in err and ".png" in err


@pytest.mark.slow
def test_a_trace_cut_mid_line_still_plots(capsys, tmp_path: Path) -> None:
    text = (BEHAVIOURS / "wall_follow.golden.csv").read_text()
    cut = tmp_path / "cut.csv"
    cut.write_text(text[: len(text) // 3 + 17])  # a run killed mid-write: half a row at the end
    assert not cut.read_text().endswith("\n")
    for out in ("map.png", "sig.png", "run.gif"):
        extra = ["--signals", "ahead"] if out == "sig.png" else []
        code, _, err = cli(capsys, "plot", str(cut), *extra, "-o", str(tmp_path / out), "--to", "20")
        assert code == 0, err


# -- animations ------------------------------------------------------------------------------

@pytest.mark.slow
def test_mp4_frames_and_size_read_back(capsys, tmp_path: Path) -> None:
    trace = write_trace(tmp_path / "run.csv", {"pioneer": straight(-5.0, -5.0, -1.0, -5.0, n=61)})
    out = tmp_path / "run.mp4"
    code, _, _ = cli(capsys, "plot", str(trace), "-o", str(out), "--fps", "10", "--width", "640")
    assert code == 0
    reader = imageio.get_reader(out, format="FFMPEG")
    try:
        count = reader.count_frames()
        first = reader.get_data(0)
        meta = reader.get_meta_data()
    finally:
        reader.close()
    # 3 s at real time and 10 frames a second: frames at 0, 0.1, ... 3.0 s
    assert count == len(frame_times(0.0, 3.0, 10, 1.0)) == 31
    assert first.shape[1] == 640 and first.shape[0] % 16 == 0
    assert meta["codec"] == "h264" and meta["fps"] == 10


def test_gif_shows_the_robot_where_the_trace_puts_it(capsys, tmp_path: Path) -> None:
    trace = write_trace(tmp_path / "run.csv", {"pioneer": straight(-5.0, -5.0, -1.0, -5.0, n=41)})
    out = tmp_path / "run.gif"
    code, _, _ = cli(capsys, "plot", str(trace), "-o", str(out), "--fps", "5", "--width", "800")
    assert code == 0
    frames = imageio.mimread(out)
    assert len(frames) == 11  # 2 s at 5 frames a second
    fig = render_figure(read_trace(trace), width_px=800, backdrop=True)
    colour = np.array(robot_colour(0))[::-1]  # BGR to RGB
    for k, x in ((0, -5.0), (10, -1.0)):
        u, v = fig.to_px(x, -5.12)  # in the robot's disc, beside the line of its heading
        assert np.abs(frames[k][round(v), round(u), :3].astype(int) - colour).max() < 40, k


def test_long_runs_are_sampled_to_a_watchable_length() -> None:
    # a 25-minute run at the defaults is 30 s of video, whatever its ticks
    times = frame_times(0.0, 1500.0, 10, 1500.0 / 30)
    assert len(times) == 301 and times[-1] == pytest.approx(1500.0)


def test_crane_animation_and_map_draw_the_crab_where_the_trace_says(capsys, tmp_path: Path) -> None:
    trace_path = crane_window(tmp_path, 20.0)  # by 20 s the crab has run out to x = 4.6
    trace = read_trace(trace_path)
    crab_x = float(trace.rows[-1][trace.columns.index("crab_x")])
    assert crab_x > 4
    world = load_world(builtin_worlds()["crane"], Report())
    assert world is not None and world.mechanism is not None
    poses = mechanism_poses(trace, world.mechanism)
    assert poses.offsets["Crab"][-1][0] + 1.0 == pytest.approx(crab_x)
    assert poses.slew is not None and poses.slew[-1] == pytest.approx(0.8, abs=0.01)
    # on the map, the crab's last pose is filled where crab_x puts it; its start is outline only
    fig = render_figure(trace, width_px=1000)
    u, v = fig.to_px(crab_x, 7.825)
    assert fig.image[round(v), round(u)].astype(int).tolist() != list(fig.image[5, 5])
    u0, v0 = fig.to_px(1.0, 7.9)
    drawn, empty = fig.image[round(v), round(u)].astype(int), fig.image[round(v0), round(u0)].astype(int)
    assert np.abs(drawn - empty).max() > 30
    # the animation's last frame has it there too
    out = tmp_path / "crane.gif"
    code, _, _ = cli(capsys, "plot", str(trace_path), "-o", str(out), "--fps", "2", "--speed", "10")
    assert code == 0
    last = imageio.mimread(out)[-1]
    backdrop = render_figure(trace, width_px=720, backdrop=True)
    u, v = backdrop.to_px(crab_x, 7.825)
    assert np.abs(last[round(v), round(u), :3].astype(int) - np.array([150, 190, 225])).max() < 40


def test_time_range_outside_the_trace_is_a_mistake(capsys, tmp_path: Path) -> None:
    code, _, err = cli(capsys, "plot", str(CRANE), "-o", str(tmp_path / "x.gif"), "--from", "100")
    assert code == 2 and "no ticks between" in err


def test_time_window_keeps_the_header(tmp_path: Path) -> None:
    trace = read_trace(crane_window(tmp_path, 5.0))
    assert isinstance(trace, Trace) and trace.header["world"] == "crane"
