"""Paths resolved before they are judged, and outputs never over inputs (docs/security.md).

A table of hostile layouts built with symbolic and hard links in a fresh folder: a world
named through a link followed by ``..`` (which spelling alone puts inside the behaviour's
folder), outputs of every command that land on an input of the run (the world file, the
replayed trace), ``labsim new`` onto links, and the pytest plugin meeting a link out of the
folder it collects. Each case runs the command in the process, in that folder, and holds it
to the exact message, exit code 2, no traceback, no secret echoed, and no file changed (the
bytes and modification times of every file, inside the folder and out, before and after).
"""
from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pytest
from helpers import FIXTURES

from labsim.backends.scene.world_names import builtin_worlds
from labsim.foundation.files import policy_problem, served_problem
from labsim.runtime.cli.main import main
from labsim.runtime.trace import read_trace, trace_world

pytest_plugins = ["pytester"]

SECRET = "token=s3cr3t-do-not-echo"
WORLD = builtin_worlds()["walls_lab4"]
OVERWRITE = ("would overwrite an input of this run ({}, by this name or a link); give the output its own file, "
             "such as run.csv")
LINK_OUT = "leads out of the behaviour's folder through the symbolic link 'd'"


def behaviour(d: Path, world: str = "w.yaml", name: str = "b.yaml") -> Path:
    """A one-second behaviour in ``d`` whose world is ``world``, and that world beside it."""
    (d / "w.yaml").write_text(WORLD.read_text())
    p = d / name
    p.write_text((FIXTURES / "minimal.yaml").read_text().replace("world: walls_lab4", f"world: {world}"))
    return p


def through_link(d: Path) -> Path:
    """``d/link`` leads to ``../other/sub``, so ``link/../x`` is ``other/x``; there, a world-shaped
    file with a secret on a line an error would echo. The behaviour names ``d/../w.yaml``."""
    (d.parent / "other" / "sub").mkdir(parents=True)
    (d.parent / "other" / "w.yaml").write_text(WORLD.read_text() + f"{SECRET}: 1\n")
    (d / "d").symlink_to(Path("..") / "other" / "sub")
    return behaviour(d, "d/../w.yaml")


def trace(d: Path) -> str:
    assert main(["run", str(behaviour(d)), "-q", "--trace", "t.csv"]) == 0
    return "t.csv"


def hard_link(d: Path, source: str, name: str) -> None:
    os.link(d / source, d / name)


def view(*args: str) -> list[str]:
    return ["view", *args, "--no-browser", "--port", "0"]


@dataclass(frozen=True)
class Case:
    name: str
    setup: Callable[[Path], list[str]]  # builds the files in the folder; the labsim arguments
    says: str  # the first line on stderr, exactly ({d}: the case's folder)


CASES = [
    # the policy judges the file the system opens: links followed, then '..'
    Case("check: world d/../w.yaml with d a link out", lambda d: (through_link(d), ["check", "b.yaml"])[1],
         f"b.yaml:3:8: error: world file 'd/../w.yaml' {LINK_OUT}"),
    Case("run: the same, --allow-path the link", lambda d: (through_link(d), ["run", "--allow-path", "d", "b.yaml"])[1],
         f"b.yaml:3:8: error: world file 'd/../w.yaml' {LINK_OUT}"),
    # outputs over the run's inputs: the message labsim run gives
    Case("run --trace over the replayed trace", lambda d: ["run", "b.yaml", "--replay", trace(d), "--trace", "t.csv"],
         "--trace t.csv: error: " + OVERWRITE.format("t.csv")),
    Case("run --json over the world file", lambda d: (behaviour(d), ["run", "b.yaml", "--json", "w.yaml"])[1],
         "--json w.yaml: error: " + OVERWRITE.format("w.yaml")),
    Case("sweep -o over the world file", lambda d: (behaviour(d), ["sweep", "b.yaml", "-o", "w.yaml"])[1],
         "-o w.yaml: error: " + OVERWRITE.format("w.yaml")),
    Case("sweep --json onto a hard link to the world file",
         lambda d: (behaviour(d), hard_link(d, "w.yaml", "s.json"), ["sweep", "b.yaml", "--json", "s.json"])[2],
         "--json s.json: error: " + OVERWRITE.format("w.yaml")),
    Case("sweep --traces: a run's trace is a link to the world file",
         lambda d: (behaviour(d), (d / "runs").mkdir(), (d / "runs" / "0000-b-seed0.csv").symlink_to(d / "w.yaml"),
                    ["sweep", "b.yaml", "--traces", "runs"])[3],
         "--traces runs/0000-b-seed0.csv: error: " + OVERWRITE.format("w.yaml")),
    Case("view --trace over the world file", lambda d: (behaviour(d), view("b.yaml", "--trace", "w.yaml"))[1],
         "--trace w.yaml: error: " + OVERWRITE.format("w.yaml")),
    Case("plot -o onto a hard link to the trace's world file",
         lambda d: (trace(d), hard_link(d, "w.yaml", "p.png"), ["plot", "t.csv", "-o", "p.png"])[2],
         "p.png: error: " + OVERWRITE.format("w.yaml")),
    Case("plot -o onto a hard link to the trace's behaviour",
         lambda d: (trace(d), hard_link(d, "b.yaml", "p.png"), ["plot", "t.csv", "-o", "p.png"])[2],
         "p.png: error: " + OVERWRITE.format("{d}/b.yaml")),  # the trace names it so
    # labsim new writes through no link
    Case("new: a dangling link where the copy goes",
         lambda d: ((d / "mine").mkdir(), (d / "mine" / "crane.yaml").symlink_to(d / "elsewhere.yaml"),
                    ["new", "crane", "mine"])[2],
         "mine/crane.yaml: error: is a symbolic link; labsim new writes no file through a link (remove it, or "
         "give another folder)"),
    Case("new: a link to a file where the golden goes",
         lambda d: ((d / "mine").mkdir(), behaviour(d), (d / "mine" / "crane.golden.csv").symlink_to(d / "w.yaml"),
                    ["new", "crane", "mine"])[3],
         "mine/crane.golden.csv: error: is a symbolic link; labsim new writes no file through a link (remove it, "
         "or give another folder)"),
    Case("new: the folder is a link to nothing",
         lambda d: ((d / "mine").symlink_to("gone"), ["new", "crane", "mine"])[1],
         "mine: error: is a symbolic link to 'gone', which does not exist; labsim new writes no file through a link"),
]


def _state(folder: Path) -> dict[str, tuple[bytes, int] | str]:
    """Every file's bytes and modification time (links as where they point), to see nothing changed."""
    out: dict[str, tuple[bytes, int] | str] = {}
    for p in sorted(folder.rglob("*")):
        if p.is_symlink():
            out[str(p)] = os.readlink(p)
        elif p.is_file():
            out[str(p)] = (p.read_bytes(), p.stat().st_mtime_ns)
    return out


@pytest.mark.parametrize("case", CASES, ids=[c.name for c in CASES])
def test_hostile_path(case: Case, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                      capsys: pytest.CaptureFixture[str]) -> None:
    d = tmp_path / "lab"
    d.mkdir()
    monkeypatch.chdir(d)
    monkeypatch.delenv("LABSIM_ALLOW_PATH", raising=False)
    args = case.setup(d)
    capsys.readouterr()
    before = _state(tmp_path)
    code = main(args)
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err and SECRET not in out + err
    assert (code, err.splitlines()[0] if err else "") == (2, case.says.replace("{d}", str(d))), out + err
    assert _state(tmp_path) == before  # no file written, none changed, no link followed


def test_the_policy_judges_the_real_path(tmp_path: Path) -> None:
    """``d/..`` is the parent of where ``d`` leads, for the access policy as for the system."""
    base, other = tmp_path / "lab", tmp_path / "other"
    (other / "sub").mkdir(parents=True)
    base.mkdir()
    (base / "d").symlink_to(other / "sub")
    (base / "in").symlink_to(base)
    (base / "loop").symlink_to(base / "loop")
    assert policy_problem("d/../w.yaml", base, []) == LINK_OUT
    assert policy_problem("d/w.yaml", base, []) == LINK_OUT
    assert policy_problem("in/../lab/w.yaml", base, []) == ""  # in/.. is tmp_path, then lab: inside
    assert policy_problem("in/w.yaml", base, []) == ""
    assert policy_problem("loop/w.yaml", base, []) == "is a loop of symbolic links"
    assert policy_problem("d/../w.yaml", base, [other]) == ""  # an allowed folder
    assert policy_problem("d/../w.yaml", base, [base / "d"]) == LINK_OUT  # d is other/sub, not other
    assert policy_problem("d/../w.yaml", base / "in", []) == LINK_OUT  # the base is resolved too
    assert served_problem("d/../x.png", base).startswith("is outside the folders labsim serve reads")


def test_a_trace_naming_a_world_through_a_link_is_drawn_without_it(tmp_path: Path,
                                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    """labsim plot (--camera too) and view read a trace's world file by the same rule."""
    d = tmp_path / "lab"
    d.mkdir()
    monkeypatch.chdir(d)
    trace(d)
    through_link(d)
    t = Path("t.csv")
    t.write_text(t.read_text().replace('"world_file": "w.yaml"', '"world_file": "d/../w.yaml"'), encoding="utf-8")
    world, note = trace_world(read_trace(t))
    assert world is not None and world.name == "walls_lab4"  # the built-in of the same name, not the file
    (d / "w.yaml").unlink()
    t.write_text(t.read_text().replace('"world": "walls_lab4"', '"world": ""'), encoding="utf-8")
    world, note = trace_world(read_trace(t))
    assert world is None and note == (f"world file d/../w.yaml not found (world file 'd/../w.yaml' {LINK_OUT}; "
                                      "--allow-path DIR reads it): drawn without walls")


def test_the_pytest_plugin_follows_no_link_out_of_the_folder(pytester: pytest.Pytester) -> None:
    outside = pytester.path.parent / f"{pytester.path.name}-outside"
    outside.mkdir()
    (outside / "b.yaml").write_text((FIXTURES / "minimal.yaml").read_text())
    (outside / "b.golden.csv").write_text(f"{SECRET}\n")
    (pytester.path / "b.yaml").symlink_to(outside / "b.yaml")
    (pytester.path / "b.golden.csv").symlink_to(outside / "b.golden.csv")
    result = pytester.runpytest("-p", "no:cacheprovider")
    assert result.ret == 2  # a collection error, as labsim test exits with 2
    result.stdout.fnmatch_lines([f"*{pytester.path / 'b.yaml'}: is a symbolic link to a file outside the "
                                 "behaviour's folder; pytest reads files found in a folder only inside it, as "
                                 "labsim test does (or in a folder LABSIM_ALLOW_PATH allows)"])
    assert SECRET not in result.stdout.str()
    named = pytester.runpytest("-p", "no:cacheprovider", str(pytester.path / "b.yaml"), "--collect-only", "-q")
    named.stdout.fnmatch_lines(["*b.yaml::b"])  # a file named on the command line is the person's own
