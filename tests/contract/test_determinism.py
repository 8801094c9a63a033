"""The same file, seed and backend give the same trace, byte for byte, in-process or not."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from helpers import BEHAVIOURS

from labsim.runtime.cli.main import main

LAB = BEHAVIOURS / "wall_follow.yaml"
SHORT = ["--set", "minutes=2", "-q"]


def test_two_runs_in_process_and_one_in_a_subprocess_are_identical(tmp_path: Path) -> None:
    a, b, c = (tmp_path / f"{n}.csv" for n in "abc")
    assert main(["run", str(LAB), *SHORT, "--trace", str(a)]) == 0
    assert main(["run", str(LAB), *SHORT, "--trace", str(b)]) == 0
    subprocess.run([sys.executable, "-m", "labsim", "run", str(LAB), *SHORT, "--trace", str(c)], check=True)
    assert a.read_bytes() == b.read_bytes() == c.read_bytes()
    assert len(a.read_bytes().splitlines()) == 2 + 2401 + 1  # header, columns, rows (the stopping tick too), footer


def test_another_seed_gives_another_run(tmp_path: Path) -> None:
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    main(["run", str(LAB), *SHORT, "--trace", str(a)])
    main(["run", str(LAB), *SHORT, "--seed", "2", "--trace", str(b)])
    assert a.read_bytes() != b.read_bytes()


@pytest.mark.slow  # seconds: two labs run three times each, one in a process of its own; handed out first
def test_the_epuck_with_ground_sensors_and_a_lidar_robot_repeat_byte_for_byte(tmp_path: Path) -> None:
    """The line-following lab (e-puck, ground sensors) and a Pioneer reading a noisy lidar and
    its bumpers: the same trace in process twice and in a subprocess."""
    lidar = tmp_path / "lidar.yaml"
    lidar.write_text("labsim: 1.2\nworld: walls_lab4\nseed: 6\nstop: time >= 20\nrobots:\n"
                     "  p: {model: pioneer_p3dx, at: random,"
                     " lidar: {beams: 90, fov_deg: 270, range_m: 3, noise: 0.02}}\n"
                     "let:\n  nearest: min(lidar1..lidar90)\n  side: argmin(lidar1..lidar90)\n"
                     "  bumped: bump_front_left or bump_front_right\n"
                     "rules:\n  - if nearest < 0.6 and side < 45 then arc(-3, 3)\n"
                     "  - if nearest < 0.6 then arc(3, -3)\n  - else move(6)\n")
    for lab, args in ((BEHAVIOURS / "line_follow.yaml", ["--set", "minutes=0.5", "-q"]), (lidar, ["-q"])):
        a, b, c = (tmp_path / f"{lab.stem}-{n}.csv" for n in "abc")
        assert main(["run", str(lab), *args, "--trace", str(a)]) == 0
        assert main(["run", str(lab), *args, "--trace", str(b)]) == 0
        subprocess.run([sys.executable, "-m", "labsim", "run", str(lab), *args, "--trace", str(c)], check=True)
        assert a.read_bytes() == b.read_bytes() == c.read_bytes()
