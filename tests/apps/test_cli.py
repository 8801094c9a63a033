"""The command line end to end: what a user types, what they see, the exit code."""
from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from helpers import BEHAVIOURS, FIXTURES, expectations

from labsim.runtime.cli.main import main

LAB = BEHAVIOURS / "wall_follow.yaml"


def cli(capsys, *args: str) -> tuple[int, str, str]:
    code = main(list(args))
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    return code, out, err


def test_run_prints_a_summary(capsys) -> None:
    code, out, err = cli(capsys, "run", str(LAB), "--set", "minutes=0.5")
    assert code == 0
    assert "done: 600 ticks, 30.00 s simulated in" in out
    assert "params: minutes=0.5* front=0.5 side=0.3 cruise=2   (* set on the command line)" in out
    assert "robot pioneer: 0 collisions" in out
    assert "rules (ticks fired):" in out and "never fired:" in out


def test_run_writes_a_trace_and_plot_draws_it(capsys, tmp_path: Path) -> None:
    trace, png = tmp_path / "run.csv", tmp_path / "run.png"
    assert cli(capsys, "run", str(LAB), "--set", "minutes=0.2", "--trace", str(trace), "-q")[0] == 0
    assert len(trace.read_text().splitlines()) == 2 + 241 + 1  # header, columns, rows and the stopping tick, footer
    code, out, _ = cli(capsys, "plot", str(trace), "-o", str(png))
    assert code == 0 and png.stat().st_size > 10_000


@pytest.mark.parametrize("args, message", [
    (["run", "nope.yaml"], "nope.yaml: error: no such behaviour file"),
    (["run", str(LAB), "--set", "fron=1.0"], "--set fron=1.0: error: unknown parameter 'fron' (did you mean 'front'?)"),
    (["run", str(LAB), "--set", "front=far"], "--set front=far: error: parameter 'front' is a number, not 'far'"),
    (["run", str(LAB), "--set", "front"], "--set front: error: --set takes NAME=VALUE, e.g. --set front=1.0"),
    (["run", str(LAB), "--trace", "/no/such/dir/t.csv"],
     "--trace /no/such/dir/t.csv: error: folder '/no/such/dir' does not exist"),
    (["run", str(FIXTURES / "structure_with_error.yaml")],
     "structure_with_error.yaml:6:8: error: unknown world 'walls_lab5'"),
    (["plot", "nope.csv", "-o", "x.png"], "nope.csv: error: no such trace file"),
    (["plot", str(LAB), "-o", "x.png"], "error: not a labsim trace"),
    (["run"], "labsim: error: the following arguments are required: file"),
])
def test_bad_input_exits_2_with_a_clear_message(capsys, args: list[str], message: str) -> None:
    try:
        code, out, err = cli(capsys, *args)
    except SystemExit as e:  # argparse's own usage errors
        code, (_, err) = e.code, capsys.readouterr()
    assert code == 2
    assert message in err


LABS_HINT = ("      = labsim labs lists the labs labsim ships; a lab's name works wherever a file does "
             "(labsim run wall_follow)\n")
TRACE_HINT = "      = a trace is what labsim run FILE --trace PATH writes\n"


@pytest.mark.parametrize("args, printed", [
    (["run", "nosuch.yaml"], "nosuch.yaml: error: no such behaviour file\n" + LABS_HINT),
    (["test", "nosuch.yaml"], "nosuch.yaml: error: no such file or folder\n" + LABS_HINT),
    (["check", "mine/wal_follow.yaml"], "mine/wal_follow.yaml: error: no such behaviour file\n"
                                        "      = labsim labs lists the labs labsim ships; a lab is given by its name: "
                                        "wall_follow\n"),
    (["run", "mine/lab2.yml"], "mine/lab2.yml: error: no such behaviour file\n      = did you mean mine/lab1.yaml?\n"
                               + LABS_HINT),
    (["run", "mine"], "mine: error: is a folder, not a behaviour file\n"
                      "      = give one behaviour file, not a folder; in it: lab1.yaml\n"
                      "      = labsim test FOLDER checks every behaviour of a folder against its golden trace\n"),
    (["run", "empty"], "empty: error: is a folder, not a behaviour file\n"
                       "      = give one behaviour file, not a folder; it holds no .yaml or .yml file\n"
                       "      = labsim test FOLDER checks every behaviour of a folder against its golden trace\n"),
    (["run", str(LAB), "--seed", "-1"], "--seed: error: the seed is 0 or a positive whole number, not -1\n"
                                        "      = a seed picks the run's random draws (the same seed, the same run): "
                                        "--seed 0, --seed 1, ...; without --seed, the file's seed: is used\n"),
    (["view", str(LAB), "--seed", "-2", "--no-browser"],
     "--seed: error: the seed is 0 or a positive whole number, not -2\n"
     "      = a seed picks the run's random draws (the same seed, the same run): "
     "--seed 0, --seed 1, ...; without --seed, the file's seed: is used\n"),
    (["plot", "nosuch.csv", "-o", "x.png"], "nosuch.csv: error: no such trace file\n" + TRACE_HINT),
    (["plot", "mine/run2.csv", "-o", "x.png"], "mine/run2.csv: error: no such trace file\n"
                                               "      = did you mean mine/run1.csv?\n" + TRACE_HINT),
    (["plot", "mine", "-o", "x.png"], "mine: error: is a folder, not a trace file\n"
                                      "      = give one trace file, not a folder; in it: run1.csv\n"),
    (["plot", "mine/run1.csv", "-o", "x.png", "--width", "300"],
     "labsim plot: error: --width must be at least 400 (got 300)\n"
     "      = 400 px is the narrowest picture labsim draws (narrower, the labels and the legend would cover "
     "the map); leave --width out for the default\n"),
    (["view", "nosuch.yaml", "--no-browser"], "nosuch.yaml: error: no such file\n" + LABS_HINT),
    (["view", "mine/run2.csv", "--no-browser"], "mine/run2.csv: error: no such file\n"
                                                "      = did you mean mine/run1.csv?\n" + TRACE_HINT),
])
def test_a_missing_file_a_folder_and_a_bad_number_say_what_to_give(capsys, monkeypatch, tmp_path: Path,
                                                                  args: list[str], printed: str) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "mine").mkdir()
    (tmp_path / "empty").mkdir()
    shutil.copy(LAB, tmp_path / "mine" / "lab1.yaml")
    (tmp_path / "mine" / "run1.csv").write_text("tick\n")
    code, out, err = cli(capsys, *args)
    assert (code, out, err) == (2, "", printed)


def test_check_reports_every_error_of_every_file(capsys) -> None:
    files = sorted(str(p) for p in FIXTURES.glob("*_with_error.yaml"))
    code, out, err = cli(capsys, "check", str(FIXTURES / "minimal.yaml"), *files)
    assert code == 2
    assert "minimal.yaml: ok" in out
    expected = sum(len(expectations(FIXTURES / Path(f).name)) for f in files)
    assert err.count(": error: ") == expected
    assert f"{expected} errors" in err


def test_golden_pass_fail_and_missing(capsys, tmp_path: Path) -> None:
    lab = tmp_path / "lab.yaml"
    shutil.copy(LAB, lab)
    lab.write_text(lab.read_text().replace("minutes: 25 ", "minutes: 0.5"))
    code, out, _ = cli(capsys, "test", str(lab))
    assert code == 1 and "FAIL" in out and "no golden trace" in out and "--update-goldens" in out
    assert cli(capsys, "test", str(lab), "--update-goldens")[0] == 0
    code, out, _ = cli(capsys, "test", str(tmp_path))
    assert code == 0 and "1 passed, 0 failed" in out
    lab.write_text(lab.read_text().replace("cruise: 2 ", "cruise: 1.5"))
    code, out, _ = cli(capsys, "test", str(lab))
    assert code == 1
    assert "first difference at tick" in out and "column '" in out
    assert "tolerance" in out and "context (golden | this run where they differ):" in out
    assert "note: the behaviour file has changed since the golden was recorded" in out


def test_python_dash_m_and_version() -> None:
    result = subprocess.run([sys.executable, "-m", "labsim", "--version"], capture_output=True, text=True)
    assert result.returncode == 0 and result.stdout.startswith("labsim ")
    result = subprocess.run([sys.executable, "-m", "labsim", "check", str(FIXTURES / "missing_then_with_error.yaml")],
                            capture_output=True, text=True)
    assert result.returncode == 2
    assert "missing_then_with_error.yaml:10:22: error: expected 'then' after the condition" in result.stderr
    assert "Traceback" not in result.stderr


def test_a_trace_never_overwrites_an_input(capsys, tmp_path: Path) -> None:
    lab = tmp_path / "lab.yaml"
    shutil.copy(LAB, lab)
    code, _, err = cli(capsys, "run", str(lab), "--trace", str(lab))
    assert code == 2 and "would overwrite an input of this run" in err
    assert lab.read_text() == LAB.read_text()


def test_test_goes_on_past_a_broken_behaviour_and_skips_world_files(capsys, tmp_path: Path) -> None:
    shutil.copy(FIXTURES / "types_with_error.yaml", tmp_path / "a_broken.yaml")
    shutil.copy(FIXTURES / "pendulum_world.yaml", tmp_path / "pendulum_world.yaml")
    lab = tmp_path / "lab.yaml"
    lab.write_text(LAB.read_text().replace("minutes: 25 ", "minutes: 0.2"))
    assert cli(capsys, "test", str(lab), "--update-goldens")[0] == 0
    code, out, err = cli(capsys, "test", str(tmp_path))
    assert code == 2  # a file that does not compile is bad input, reported after the others ran
    assert "FAIL" in out and "a_broken.yaml: it does not compile" in out and "ok   " in out
    assert "pendulum_world" not in out
    assert "types_with_error" not in err and "a_broken.yaml:11:8: error:" in err


def test_output_to_a_closed_pipe_is_not_an_error() -> None:
    result = subprocess.run(f"{sys.executable} -m labsim run {LAB} --set minutes=0.1 | head -1",
                            shell=True, capture_output=True, text=True)
    assert "Traceback" not in result.stderr and result.stdout.startswith("Wall following")


def test_replay_flag_feeds_a_traces_slider_moves_back(capsys, tmp_path: Path) -> None:
    crane = BEHAVIOURS / "crane.yaml"
    first, second = tmp_path / "first.csv", tmp_path / "second.csv"
    assert cli(capsys, "run", str(crane), "-q", "--trace", str(first))[0] == 0
    assert cli(capsys, "run", str(crane), "-q", "--trace", str(second), "--replay", str(first))[0] == 0
    assert first.read_text().splitlines()[1:] == second.read_text().splitlines()[1:]


def test_check_json_lists_every_diagnostic_with_its_position_and_the_same_exit_code(capsys) -> None:
    import json

    files = sorted(str(f) for f in FIXTURES.glob("*_with_error.yaml"))[:3]
    code, out, err = cli(capsys, "check", "--json", str(FIXTURES / "minimal.yaml"), *files)
    assert code == 2 and err == ""
    found = json.loads(out)
    assert [f["file"] for f in found["files"]] == [str(FIXTURES / "minimal.yaml"), *files]
    assert found["files"][0] == {"file": str(FIXTURES / "minimal.yaml"), "errors": 0, "warnings": 0}
    for f in files:  # every error the file's own comments expect, none cut
        got = {(d["line"], d["column"]) for d in found["diagnostics"] if d["file"] == f}
        assert {(line, col) for line, col, _ in expectations(Path(f))} <= got
    d = found["diagnostics"][0]
    assert set(d) >= {"file", "line", "column", "severity", "message", "hint"}
    code, out, _ = cli(capsys, "check", "--json", str(FIXTURES / "minimal.yaml"))
    assert code == 0 and json.loads(out)["diagnostics"] == []
