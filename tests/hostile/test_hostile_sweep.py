"""A sweep's options, hostile or careless (docs/sweep.md, "Limits"): a grid too large, ranges of
huge, infinite or not-a-number values, seeds by the hundred thousand, a step below what a value
prints. Each is labsim's own message and exit 2, before anything runs, in bounded memory."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from helpers import BEHAVIOURS

from labsim.foundation.diagnostics import LabsimError
from labsim.runtime.cli.main import main
from labsim.runtime.sweep.driver import DEFAULT_TIMEOUT_S, SweepOptions
from labsim.runtime.sweep.grid import MAX_GRID, grid_size, parse_seeds, parse_setting

LAB = str(BEHAVIOURS / "wall_follow.yaml")
HUGE = "9" * 5000  # a number no float holds


@pytest.mark.parametrize(("args", "message"), [
    # grids over the maximum, counted without being built: 120,000 and 1.25 * 10^14 runs
    (["--seeds", "1-60000", "--set", "front=1,2"], "this grid has 120,000 runs (1 file x 2 values of front x "
                                                   "60,000 seeds); a sweep has at most 100,000"),
    (["--set", "front=1:50000:1", "--set", "side=1:50000:1", "--seeds", "1-50000"],
     "this grid has 125,000,000,000,000 runs"),
    (["--set", "front=0:1:1e-300"], "this range has more than 1,000,000 values; a sweep has at most 100,000 runs"),
    (["--set", "front=-1e308:1e308:1e-308"], "this range has more than 1,000,000 values"),  # (stop-start)/step: inf
    (["--set", "front=0:1e999:1"], "a range is START:STOP:STEP with three finite numbers"),
    (["--set", f"front=0:{HUGE}:1"], "a range is START:STOP:STEP with three finite numbers"),
    (["--set", "front=nan:1:0.5"], "a range is START:STOP:STEP with three finite numbers"),
    (["--set", "front=0:inf:1"], "a range is START:STOP:STEP with three finite numbers"),
    (["--set", "front=1:2:-inf"], "a range is START:STOP:STEP with three finite numbers"),
    (["--set", "front=1e16:1.0000000000000002e16:0.5"], "the step 0.5 is too small to change a number near 1e+16"),
    (["--set", "front=1e999"], "parameter 'front': number too large"),
    (["--set", f"front={HUGE}"], "parameter 'front': number too large"),
    (["--set", "front=nan"], "parameter 'front' must be a finite number"),
    (["--seeds", "0-9007199254740993"], "is not a range of seeds (0 to 2**53, low-high)"),
    (["--seeds", f"1-{HUGE}"], "seeds are whole numbers"),
    (["--seeds", "0-99999,100000-199999"], "too many seeds; a sweep has at most 100,000 runs"),
])
def test_a_hostile_option_is_refused_before_anything_runs(capsys, tmp_path: Path, args: list[str],
                                                          message: str) -> None:
    out_csv = tmp_path / "r.csv"
    code = main(["sweep", LAB, *args, "-o", str(out_csv)])
    out, err = capsys.readouterr()
    assert code == 2 and message in err, err
    assert "Traceback" not in out + err and not out_csv.exists()


def test_a_grid_of_ten_to_the_twelve_is_refused_in_bounded_memory() -> None:
    """Peak RSS of the whole ``labsim sweep`` process (measured as its parent's child usage)."""
    probe = ("import resource, subprocess, sys\n"
             "r = subprocess.run([sys.executable, '-m', 'labsim', 'sweep', sys.argv[1], '--set', 'front=1:1000000:1',"
             " '--set', 'side=1:1000000:1', '--seeds', '1-99999'], capture_output=True, text=True)\n"
             "print(r.returncode, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss // 1024)\n"
             "print(r.stderr)\n")
    done = subprocess.run([sys.executable, "-c", probe, LAB], capture_output=True, text=True, timeout=120)
    code, peak_mib = (int(v) for v in done.stdout.split("\n", 1)[0].split())
    assert code == 2 and "this range has 1,000,000 values" in done.stdout and "Traceback" not in done.stdout
    assert peak_mib < 150, peak_mib


def test_a_step_below_print_precision_gives_distinct_values() -> None:
    """1,001 runs of 0.5:0.5000001:1e-10 are 1,001 values, each shown with the digits it needs."""
    values = parse_setting("front=0.5:0.5000001:1e-10").values
    assert len(values) == len(set(values)) == 1001
    assert (values[0], values[1], values[-1]) == ("0.5", "0.5000000001", "0.5000001")
    assert parse_setting("front=0.1:0.3:0.1").values == ("0.1", "0.2", "0.3")  # 10 digits where they do
    assert [float(v) for v in parse_setting("x=0:1:0.1").values] == [k / 10 for k in range(11)]


def test_seeds_are_parsed_in_one_pass() -> None:
    """Two ranges of 50,000 (and overlapping ranges): the right seeds, each once, in order. A
    repeat is found by a dict, not by scanning the seeds so far (which took 52 s for two 100k ranges)."""
    seeds = parse_seeds("0-49999,50000-99998")
    assert seeds == tuple(range(99999))
    assert parse_seeds("5-9,1-7,3") == (5, 6, 7, 8, 9, 1, 2, 3, 4)
    assert parse_seeds("1-49999,1-49999") == tuple(range(1, 50000))
    with pytest.raises(LabsimError):
        parse_seeds("0-99999,100000-100001")


def test_the_grid_is_counted_not_built() -> None:
    settings = [parse_setting("a=1:99999:1"), parse_setting("b=1:99999:1")]
    assert grid_size(["x.yaml"] * 3, settings, (1, 2)) == 3 * 99999 * 99999 * 2 > MAX_GRID


def test_a_run_has_a_default_time_limit() -> None:
    assert SweepOptions(["x.yaml"]).timeout_s == DEFAULT_TIMEOUT_S == 600
