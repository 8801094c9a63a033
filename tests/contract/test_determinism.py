"""The same file, seed and backend give the same trace, byte for byte, in-process or not."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

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
    assert len(a.read_bytes().splitlines()) == 2 + 2400 + 1  # header, columns, rows, footer


def test_another_seed_gives_another_run(tmp_path: Path) -> None:
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    main(["run", str(LAB), *SHORT, "--trace", str(a)])
    main(["run", str(LAB), *SHORT, "--seed", "2", "--trace", str(b)])
    assert a.read_bytes() != b.read_bytes()
