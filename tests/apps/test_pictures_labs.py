"""labsim plot of a lab run by name: the pictures find the lab's behaviour file wherever labsim is
installed (by the header's path, or by its hash), with no --allow-path; a picture drawn without
the behaviour file says what it lacks and how to give it."""
from __future__ import annotations

import os
import re
import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest
from helpers import BEHAVIOURS

from labsim.foundation.files import ALLOW_ENV
from labsim.runtime.cli.main import main
from labsim.runtime.labs import LABS_DIR
from labsim.runtime.pictures.plot import render_figure
from labsim.runtime.trace import read_trace

CRANE = BEHAVIOURS / "crane.golden.csv"


def cli(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str, str]:
    code = main(list(args))
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    return code, out, err


def crane_naming(tmp_path: Path, behaviour: str, sha256: str = "") -> Path:
    """The crane's golden trace in tmp_path, its header naming another behaviour path (and hash)."""
    text = CRANE.read_text()
    first, rest = text.split("\n", 1)
    first = first.replace('"behaviour": "behaviours/crane.yaml"', f'"behaviour": "{behaviour}"')
    if sha256:
        first = re.sub(r'(?<=[{ ])"sha256": "[0-9a-f]{64}"', f'"sha256": "{sha256}"', first)
    out = tmp_path / "c.csv"
    ticks = rest.count("\n") - 1  # the rows, without the columns line
    out.write_text(first + "\n" + rest + f'# end {{"interrupted": false, "ticks": {ticks}}}\n')
    return out


def panels_of(png: Path, trace: Path) -> tuple[str, ...]:
    """The panels of the map the command line wrote: it is the figure render_figure draws."""
    fig = render_figure(read_trace(trace), width_px=1000)
    assert np.array_equal(cv2.imread(str(png)), fig.image)
    return fig.panels


def test_crane_run_by_name_plots_its_slew_panel(capsys, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv(ALLOW_ENV, raising=False)
    assert main(["run", "crane", "--trace", "c.csv", "-q"]) == 0
    named = Path(str(read_trace("c.csv").header["behaviour"]))
    assert named.resolve().parent == LABS_DIR  # the installed package's file, outside this folder
    code, printed, err = cli(capsys, "plot", "c.csv", "-o", "c.png")
    assert code == 0 and "wrote c.png" in printed and err == ""
    assert panels_of(tmp_path / "c.png", tmp_path / "c.csv") == ("slew panel",)


def test_camera_of_the_road_lab_run_by_name_needs_no_allow_path(
        capsys, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv(ALLOW_ENV, raising=False)
    assert main(["run", "road_follow", "--set", "seconds=0.5", "--trace", "road.csv", "-q"]) == 0
    code, printed, err = cli(capsys, "plot", "road.csv", "--camera", "pioneer[1]", "-o", "road.png")
    assert code == 0 and "wrote road.png" in printed and err == ""
    assert ALLOW_ENV not in os.environ  # nothing opened the package's folder to other files


def test_a_lab_of_another_install_is_found_by_its_hash(capsys, tmp_path: Path) -> None:
    # a trace made on another machine names that machine's package, which is not here
    trace = crane_naming(tmp_path, "/elsewhere/site-packages/labsim/behaviours/crane.yaml")
    code, _, err = cli(capsys, "plot", str(trace), "-o", str(tmp_path / "c.png"))
    assert code == 0 and err == ""
    assert panels_of(tmp_path / "c.png", trace) == ("slew panel",)


def test_a_picture_without_its_behaviour_file_says_what_it_lacks(capsys, tmp_path: Path) -> None:
    # a student's own crane, edited (another hash) and since moved away from where it ran
    trace = crane_naming(tmp_path, "/gone/mine/crane.yaml", sha256="0" * 64)
    out = tmp_path / "c.png"
    code, printed, err = cli(capsys, "plot", str(trace), "-o", str(out))
    assert code == 0 and f"wrote {out}" in printed
    assert err == (f"{trace}: warning: drawn without the slew panel and the moves of Crab and Gripper, which need "
                   "the behaviour file that made the trace: the trace names /gone/mine/crane.yaml, which is not "
                   "there; pass --behaviour PATH\n")
    assert panels_of(out, trace) == ()
    # --behaviour gives it back, and says that file is not the one the run used
    code, _, err = cli(capsys, "plot", str(trace), "-o", str(out), "--behaviour", "crane")
    assert code == 0
    lab = LABS_DIR / "crane.yaml"  # a lab's name names its file
    assert err == (f"{trace}: warning: --behaviour {lab}: this file is not the one the run used (it was edited "
                   "since, or is another file): the pictures read it as it is now\n")
    fig = render_figure(read_trace(trace), width_px=1000)
    assert fig.panels == () and not np.array_equal(cv2.imread(str(out)), fig.image)  # the slew panel is in


def test_a_chart_without_its_behaviour_file_says_what_it_lacks(capsys, tmp_path: Path) -> None:
    trace = crane_naming(tmp_path, "/gone/mine/crane.yaml", sha256="0" * 64)
    code, _, err = cli(capsys, "plot", str(trace), "--signals", "swing,x", "-o", str(tmp_path / "s.png"))
    assert code == 0
    assert err == (f"{trace}: warning: drawn without the units of swing, which needs the behaviour file that "
                   "made the trace: the trace names /gone/mine/crane.yaml, which is not there; pass --behaviour "
                   "PATH\n")


def test_a_missing_behaviour_given_is_exit_2(capsys, tmp_path: Path) -> None:
    code, _, err = cli(capsys, "plot", str(CRANE), "-o", str(tmp_path / "c.png"), "--behaviour",
                       str(tmp_path / "nope.yaml"))
    assert code == 2 and "nope.yaml: error: no such behaviour file" in err


def test_a_users_file_outside_the_traces_folder_still_needs_leave(
        capsys, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # the shipped labs are labsim's own; a user's file elsewhere is read only when the user says so
    mine = tmp_path / "mine"
    mine.mkdir()
    lab = mine / "road.yaml"
    lab.write_text((LABS_DIR / "road_follow.yaml").read_text() + "# my copy\n")
    (tmp_path / "runs").mkdir()
    monkeypatch.chdir(tmp_path / "runs")
    monkeypatch.delenv(ALLOW_ENV, raising=False)
    assert main(["run", str(lab), "--set", "seconds=0.5", "--trace", "road.csv", "-q"]) == 0
    code, _, err = cli(capsys, "plot", "road.csv", "--camera", "pioneer[1]", "-o", "road.png")
    assert code == 2
    assert (f"the trace names {lab}, outside the trace's folder and the current one, which labsim reads only if "
            f"you name it: --behaviour {lab} (or --allow-path {mine}, docs/security.md)") in err
    assert cli(capsys, "plot", "road.csv", "--camera", "pioneer[1]", "-o", "road.png", "--behaviour", str(lab))[0] == 0
    shutil.rmtree(mine)
