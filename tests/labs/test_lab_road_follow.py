"""The road-following lab: five camera robots, one behaviour, each with its own PID."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from helpers import BEHAVIOURS, LabRun

from labsim.runtime.cli.main import main
from labsim.runtime.result import RunResult

LAB = BEHAVIOURS / "road_follow.yaml"


def assert_all_on_the_road(summary: RunResult, seconds: float, max_offset_m: float) -> None:
    assert summary.sim_time_s == seconds and len(summary.robots) == 5
    for name, robot in summary.robots.items():
        m = robot.metrics
        assert m["off_road"] == 0 and m["lateral_max"] < max_offset_m, (name, m)
        assert robot.contacts == 0 and robot.clamped_ticks == 0, name
        assert 0.48 < m["mean_speed"] < 0.49, name  # v = 5 rad/s is 0.4875 m/s
    assert summary.faults == ()  # every frame saw road


@pytest.mark.slow  # seconds: five camera robots for 30 s (shared with the module's other tests); handed out first
def test_with_the_lab_constants_all_five_stay_on_the_road_for_30_s(lab_run: LabRun) -> None:
    summary = lab_run(LAB)
    assert_all_on_the_road(summary, 30.0, 0.75)  # the road is 3 m wide
    assert summary.fleet["lateral_rms"] < 0.1


@pytest.mark.slow
@pytest.mark.long
def test_with_the_lab_constants_all_five_stay_on_the_road_for_ten_minutes(lab_run: LabRun) -> None:
    summary = lab_run(LAB, seconds="600")
    # in the curves the camera, looking ahead, cuts corners by about a third of a metre,
    # steady, not growing (docs/road-following.md)
    assert_all_on_the_road(summary, 600.0, 0.5)
    assert 0.2 < summary.fleet["lateral_rms"] < 0.35


@pytest.mark.slow
@pytest.mark.long
def test_a_camera_looking_just_ahead_lets_the_lab_gains_weave_off_the_road(tmp_path: Path,
                                                                          lab_run: LabRun) -> None:
    # what the behaviour file's comment and docs/road-following.md say about its camera
    lab = tmp_path / "near_camera.yaml"
    text = LAB.read_text()
    near = text.replace("fov_deg: 40, height_m: 3, pitch_deg: 30", "fov_deg: 60, height_m: 0.5, pitch_deg: 30")
    assert near != text
    lab.write_text(near)
    summary = lab_run(lab, seconds="600")
    assert summary.fleet["off_road"] > 60.0 and summary.fleet["lateral_max"] > 5.0


@pytest.mark.slow
@pytest.mark.long
def test_with_more_gain_the_near_camera_holds_the_compact_loop(tmp_path: Path, lab_run: LabRun) -> None:
    # docs/road-following.md: road_compact is for controllers with real proportional gain
    lab = tmp_path / "compact.yaml"
    text = LAB.read_text()
    compact = (text.replace("world: road_loop", "world: road_compact")
               .replace("fov_deg: 40, height_m: 3, pitch_deg: 30", "fov_deg: 60, height_m: 0.5, pitch_deg: 30"))
    assert compact.count("road_compact") == 1 and "pitch_deg: 30" in compact
    lab.write_text(compact)
    summary = lab_run(lab, seconds="600", kp="1.5")
    assert_all_on_the_road(summary, 600.0, 0.6)
    assert all(robot.metrics["laps"] == 2 for robot in summary.robots.values())


@pytest.mark.slow
def test_the_fleet_run_is_deterministic(tmp_path: Path) -> None:
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    assert main(["run", str(LAB), "--set", "seconds=5", "-q", "--trace", str(a)]) == 0
    subprocess.run([sys.executable, "-m", "labsim", "run", str(LAB), "--set", "seconds=5", "-q",
                    "--trace", str(b)], check=True)
    assert a.read_bytes() == b.read_bytes()
    rows = a.read_text().splitlines()[2:-1]  # without the header, the columns and the footer
    assert len(rows) == 5 * 100 and {r.split(",")[2] for r in rows} == {f"pioneer[{i}]" for i in range(5)}


@pytest.mark.slow
def test_the_golden_trace_holds(capsys) -> None:
    assert main(["test", str(LAB)]) == 0
    assert "1 passed, 0 failed" in capsys.readouterr().out
