"""The README's speed table is what benchmarks/run_all.py prints, and says the truth about its goals.

The figures themselves are not checked (speed on a shared machine is noise); what is: the table
is the script's block, each row's goal is the one the script holds for those sides, and a row
marks its goal met exactly when its CPU ratio meets it.
"""
from __future__ import annotations

import importlib.util
import re
import subprocess
import sys

import pytest
from helpers import BENCHMARKS, ROOT

_spec = importlib.util.spec_from_file_location("run_all", BENCHMARKS / "run_all.py")
assert _spec is not None and _spec.loader is not None
run_all = importlib.util.module_from_spec(_spec)
sys.modules.setdefault("run_all", run_all)  # its dataclasses look their module up there
_spec.loader.exec_module(run_all)


def table_rows(text: str) -> list[list[str]]:
    (block,) = run_all.TABLE.findall(text)
    return [[cell.strip() for cell in line.strip().strip("|").split("|")]
            for line in block.splitlines() if line.startswith("| ") and not line.startswith("| what")]


def test_the_readme_quotes_the_scripts_table_with_its_goals_marked_truly() -> None:
    rows = table_rows((ROOT / "README.md").read_text(encoding="utf-8"))
    measured = [r for r in rows if r[2]]
    assert measured, "no measured row: python benchmarks/run_all.py --markdown --write README.md"
    for what, sides, cpu, _wall, goal, _seconds in measured:
        top, bottom = sides.split(" / ", 1)
        expected = run_all.GOALS.get((top, bottom))
        if expected is None:
            assert goal == "reference", (what, sides)
            continue
        met = expected.met(float(cpu))
        assert goal == f"{expected}: {'met' if met else '**not met**'}", (what, sides, cpu)


def test_a_goal_not_met_is_marked() -> None:
    rows = [run_all.Row("wall lab", "labsim", "labsim's internals, by hand", run_all.Goal(1.05), 1.066, 1.1,
                        {"labsim": (1.52, 1.60), "labsim's internals, by hand": (1.43, 1.50)}),
            run_all.Row("vs IR-SIM", "IR-SIM", "labsim", run_all.Goal(26, most=False), 28.3, float("nan"),
                        {"IR-SIM": (0.001, 0.002), "labsim": (3.5e-05, 7e-05)})]
    table = run_all.markdown(rows, "header", ["against X: not installed"])
    assert ("| 1.066 | 1.100 | <= 1.05: **not met** | labsim 1.52 s / 1.6 s; "
            "labsim's internals, by hand 1.43 s / 1.5 s |") in table
    assert "| 28.300 |  | >= 26: met | IR-SIM 1000.0 µs / 2000.0 µs; labsim 35.0 µs / 70.0 µs |" in table
    assert "| against X | | | | | not measured: not installed |" in table


@pytest.mark.slow  # two short runs of the wall lab, three times
def test_run_all_measures_a_row_and_writes_only_its_block(tmp_path) -> None:
    readme = tmp_path / "README.md"
    readme.write_text(f"before\n{run_all.MARKER}old\n<!-- end speed table -->\nafter\n")
    done = subprocess.run([sys.executable, str(BENCHMARKS / "run_all.py"), "--markdown", "--repeat", "1",
                           "--minutes", "0.05", "--rows", "features", "--write", str(readme)],
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    text = readme.read_text()
    assert text.startswith("before\n") and text.endswith("<!-- end speed table -->\nafter\n")
    assert [r[1] for r in table_rows(text)] == ["traced / plain", "noise / plain"]
    assert re.search(r"load average [\d.]+ [\d.]+ at the start", text)
