"""First-hour papercuts: the hints a new user follows work, and what the summary shows is each robot's."""
from __future__ import annotations

import os
from pathlib import Path

from helpers import BEHAVIOURS, ROOT

from labsim.runtime.cli.main import main

LAB = BEHAVIOURS / "wall_follow.yaml"
WORLD = ROOT / "backends" / "scene" / "worlds" / "walls_lab4.yaml"


def cli(capsys, *args: str) -> tuple[int, str, str]:
    code = main(list(args))
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    return code, out, err


def test_a_world_file_run_as_a_behaviour_hints_a_command_that_works(capsys, tmp_path: Path) -> None:
    code, _, err = cli(capsys, "run", str(WORLD))
    assert code == 2
    assert ("= run a behaviour with 'world: walls_lab4' in it; 'labsim new wall_follow my_lab' copies a lab into "
            "the folder my_lab to start from (labsim labs lists the labs), and docs/worlds.md describes world "
            "files") in err
    here = Path.cwd()
    os.chdir(tmp_path)
    try:
        assert cli(capsys, "new", "wall_follow", "my_lab")[0] == 0  # the hint, typed as it reads
    finally:
        os.chdir(here)
    assert (tmp_path / "my_lab" / "wall_follow.yaml").is_file()


def test_several_values_for_run_point_at_sweep(capsys) -> None:
    code, _, err = cli(capsys, "run", str(LAB), "--set", "front=1,3,8")
    assert code == 2
    assert err.splitlines() == [
        "--set front=1,3,8: error: parameter 'front' is a number, not '1,3,8'",
        f"      = a run takes one value; to try several, use labsim sweep {LAB} --set front=1,3,8"]


def test_a_list_for_a_run_points_at_sweep_with_comma_separated_values(capsys) -> None:
    code, _, err = cli(capsys, "run", str(LAB), "--set", "front=[1, 3]")
    assert code == 2
    assert err.splitlines() == [
        "--set front=[1, 3]: error: parameter 'front' is a number, not '[1, 3]'",
        f"      = a run takes one value; to try several, use labsim sweep {LAB} --set front=1,3"]


def test_a_behaviour_given_as_a_trace_says_to_run_it_with_trace_first(capsys, tmp_path: Path) -> None:
    wanted = (f"{LAB}: error: not a labsim trace (no '# labsim-trace' header line): it is a behaviour file; run it "
              f"with --trace first (labsim run {LAB} --trace run.csv), then give run.csv")
    code, _, err = cli(capsys, "plot", str(LAB), "-o", str(tmp_path / "x.png"))
    assert code == 2 and err.strip() == wanted
    code, _, err = cli(capsys, "run", str(LAB), "--replay", str(LAB))
    assert code == 2 and err.strip() == wanted


def test_the_summary_shows_each_robots_own_parameter(capsys, tmp_path: Path) -> None:
    path = tmp_path / "three.yaml"
    path.write_text("labsim: 1.1\nworld: walls_lab4\nstop: time >= 1\nrobots:\n"
                    "  pioneer: {model: pioneer_p3dx, count: 3, at: random, params: {front: [0.3, 0.5, 0.8]}}\n"
                    "params:\n  front: 0.5\n  speed: 4\nrules:\n  - if sonar5 <= front then arc(-2, 2)\n"
                    "  - else move(speed + index)\n")
    code, out, _ = cli(capsys, "run", str(path), "--set", "speed=3")
    assert code == 0
    assert ("  params: front=(each robot's below) speed=3*   (* set on the command line)\n"
            "    front: pioneer[0]=0.3 pioneer[1]=0.5 pioneer[2]=0.8\n") in out


def test_the_readme_says_what_the_copied_schema_is_for() -> None:
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    new = readme.index("`labsim new crane mylab/`")
    assert "`behaviour.schema.json` it copies beside the lab is for your editor" in readme[new:new + 300]
