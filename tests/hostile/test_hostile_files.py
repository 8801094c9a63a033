"""The catalogue of hostile files, as a table: special files, sizes, the file system saying no,
outputs that are inputs, paths out of a behaviour's folder, damaged traces (issues 18 and 19).

Each case builds its files in a fresh folder, runs ``labsim`` there as a user would, and holds
it to the rules of docs/security.md: the exit code, a message that names the path and what is
wrong, no traceback, bounded output, no changed input, and an end within a generous timeout
(a FIFO would otherwise hang the run forever).
"""
from __future__ import annotations

import hashlib
import os
import resource
import shutil
import signal
import subprocess
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pytest
from helpers import ROOT, cases

pytestmark = pytest.mark.slow  # every case is a labsim process of its own

LAB = ROOT / "behaviours" / "wall_follow.yaml"
TIMEOUT_S = 60.0  # generous: the point is that it ends at all
MAX_OUTPUT = 20_000  # bytes of stdout + stderr a case may print
SECRET = "token=s3cr3t-do-not-echo"
LONG_NAME = "w" * 300 + ".yaml"


@dataclass(frozen=True)
class Case:
    name: str
    setup: Callable[[Path], list[str]]  # builds the files in the folder; the labsim arguments
    code: int
    says: tuple[str, ...]  # each must be in the output (the path, and what is wrong)
    never: tuple[str, ...] = (SECRET,)  # must not be in it
    as_root_too: bool = True  # root reads any folder: permission cases need another user
    limit_file_bytes: int = 0  # RLIMIT_FSIZE for the run (a disk that fills up)


def behaviour(d: Path, world: str = "walls_lab4", name: str = "b.yaml") -> Path:
    p = d / name
    p.write_text(LAB.read_text().replace("world: walls_lab4", f"world: {world}")
                 .replace("minutes: 25", "minutes: 0.05"))
    return p


def fifo(d: Path, name: str) -> str:
    os.mkfifo(d / name)
    return name


def secret(path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(f"machine grader\n{SECRET}\n")
    return path


def trace(d: Path, edit: Callable[[list[list[str]], list[str]], None] | None = None) -> str:
    """A short run's trace, with a cell changed by ``edit(rows, columns)``."""
    out = d / "trace.csv"
    subprocess.run([sys.executable, "-m", "labsim", "run", str(LAB), "--set", "minutes=0.05", "--trace",
                    str(out), "-q"], check=True, timeout=TIMEOUT_S, cwd=d)
    if edit is not None:
        lines = out.read_text().splitlines()
        columns = lines[1].split(",")
        rows = [line.split(",") for line in lines[2:-1]]
        edit(rows, columns)
        out.write_text("\n".join(lines[:2] + [",".join(r) for r in rows] + lines[-1:]) + "\n")
    return out.name


def set_cell(row: int, column: str, value: str) -> Callable[[list[list[str]], list[str]], None]:
    def edit(rows: list[list[str]], columns: list[str]) -> None:
        rows[row][columns.index(column)] = value
    return edit


def locked_world(d: Path) -> list[str]:
    (d / "locked").mkdir()
    (d / "locked" / "w.yaml").write_text("labsim-world: 1\n")
    (d / "locked").chmod(0)
    behaviour(d, "locked/w.yaml")
    return ["check", "b.yaml"]


def link_out(d: Path) -> list[str]:
    secret(d.parent / f"{d.name}-outside" / "w.yaml")
    (d / "w.yaml").symlink_to(d.parent / f"{d.name}-outside" / "w.yaml")
    behaviour(d, "w.yaml")
    return ["check", "b.yaml"]


def hard_link_trace(d: Path) -> list[str]:
    behaviour(d)
    os.link(d / "b.yaml", d / "run.csv")
    return ["run", "b.yaml", "--trace", "run.csv"]


def folder_link_out(d: Path) -> list[str]:
    (d / "labs").mkdir()
    behaviour(d / "labs")
    secret(d / "elsewhere" / "notes.yaml")
    (d / "labs" / "notes.yaml").symlink_to(d / "elsewhere" / "notes.yaml")
    return ["test", "labs"]


CASES = [
    # special files: refused before any read, so nothing hangs or fills memory
    Case("behaviour is a FIFO", lambda d: ["run", fifo(d, "b.yaml")], 2, ("b.yaml: error: is a FIFO",)),
    Case("behaviour is /dev/zero", lambda d: ["run", "/dev/zero"], 2, ("/dev/zero: error: is a device",)),
    Case("behaviour is a folder", lambda d: ["check", "."], 2, (".: error: is a folder",)),
    Case("--replay is a FIFO", lambda d: ["run", str(behaviour(d)), "--replay", fifo(d, "t.csv")], 2,
         ("t.csv: error: is a FIFO (named pipe), not a trace file",)),
    Case("--replay is /dev/zero", lambda d: ["run", str(behaviour(d)), "--replay", "/dev/zero"], 2,
         ("/dev/zero: error: is a device, not a trace file",)),
    Case("serve --for a FIFO", lambda d: ["serve", "--port", "0", "--for", fifo(d, "b.yaml")], 2,
         ("b.yaml: error: is a FIFO",)),
    Case("plot a FIFO", lambda d: ["plot", fifo(d, "t.csv"), "-o", "p.png"], 2, ("t.csv: error: is a FIFO",)),
    Case("labsim test a FIFO among the files", lambda d: (behaviour(d), fifo(d, "x.yaml"), ["test", "."])[2],
         2, ("x.yaml: error: is a FIFO",)),
    Case("world file is a FIFO", lambda d: (behaviour(d, fifo(d, "w.yaml")), ["check", "b.yaml"])[1], 2,
         ("w.yaml: error: is a FIFO",)),
    # sizes, checked before reading
    Case("behaviour of 2 MB", lambda d: ((d / "b.yaml").write_text("#" * 2_000_000), ["check", "b.yaml"])[1], 2,
         ("b.yaml: error: file is 2.0 MB; behaviour files are limited to 1024 KiB",)),
    Case("trace of 2 GiB (sparse)",
         lambda d: (os.truncate(d / trace(d), 2 << 30), ["plot", "trace.csv", "-o", "p.png"])[1], 2,
         ("trace.csv: error: file is 2147.5 MB; trace files are limited to 1024 MiB",)),
    # the file system says no
    Case("world name of 300 characters", lambda d: (behaviour(d, LONG_NAME), ["check", "b.yaml"])[1], 2,
         ("b.yaml:11:8: error: world file", "cannot be opened: file name too long")),
    Case("behaviour name of 300 characters", lambda d: ["run", LONG_NAME], 2, ("file name too long",)),
    Case("world in a folder the user may not enter", locked_world, 2,
         ("locked/w.yaml: error: cannot read the world file: permission denied",), as_root_too=False),
    # outputs that are inputs, or no files at all
    Case("--trace a hard link to the behaviour", hard_link_trace, 2,
         ("--trace run.csv: error: would overwrite an input of this run",)),
    Case("--trace the behaviour itself", lambda d: ["run", str(behaviour(d)), "--trace", "b.yaml"], 2,
         ("--trace b.yaml: error: would overwrite an input of this run",)),
    Case("--trace /dev/full", lambda d: ["run", str(behaviour(d)), "--trace", "/dev/full"], 2,
         ("--trace /dev/full: error: is a device; labsim writes regular files only",)),
    Case("--json /dev/full", lambda d: ["run", str(behaviour(d)), "--json", "/dev/full"], 2,
         ("--json /dev/full: error: is a device",)),
    Case("plot onto a hard link to its trace", lambda d: (os.link(d / trace(d), d / "p.png"),
                                                          ["plot", "trace.csv", "-o", "p.png"])[1], 2,
         ("p.png: error: would overwrite an input of this run (trace.csv",)),
    Case("a disk that fills while the trace is written", lambda d: ["run", str(LAB), "--trace", "run.csv"], 2,
         ("run.csv: error: cannot write run.csv: file too large", "interrupted:"), limit_file_bytes=100_000),
    Case("a full disk for the summary's JSON", lambda d: ["run", str(behaviour(d)), "--json", "s.json"], 2,
         ("s.json: error: cannot write s.json: file too large", "done: 60 ticks"), limit_file_bytes=1),
    # the access policy: a behaviour reads its own folder only
    Case("world: /etc/passwd", lambda d: (behaviour(d, "/etc/passwd"), ["check", "b.yaml"])[1], 2,
         ("b.yaml:11:8: error: world file '/etc/passwd' is an absolute path", "--allow-path"), ("root:",)),
    Case("world: ../outside", lambda d: (secret(d.parent / f"{d.name}-x" / "w.yaml"),
                                         behaviour(d, f"../{d.name}-x/w.yaml"), ["run", "b.yaml"])[2], 2,
         ("b.yaml:11:8: error: world file", "leads out of the behaviour's folder")),
    Case("world: a link out of the folder", link_out, 2,
         ("b.yaml:11:8: error: world file 'w.yaml' is a symbolic link",)),
    Case("world allowed, but no world file", lambda d: (secret(d / "x" / "w.yaml"), behaviour(d, "/dev/null"),
                                                        (d / "b.yaml").write_text((d / "b.yaml").read_text().replace(
                                                            "/dev/null", str(d / "x" / "w.yaml"))),
                                                        ["check", "--allow-path", "x", "b.yaml"])[3], 2,
         ("w.yaml: error: not a labsim world file", "its contents are not shown")),
    Case("world is binary", lambda d: ((d / "w.yaml").write_bytes(b"\x89PNG\r\n\x1a\n\xff" + SECRET.encode()),
                                       behaviour(d, "w.yaml"), ["check", "b.yaml"])[2], 2,
         ("w.yaml:1:1: error: not UTF-8 text: save the file as UTF-8",), (SECRET, "PNG")),
    Case("world YAML that does not parse", lambda d: ((d / "w.yaml").write_text(f"a: [\n{SECRET}: {{\n"),
                                                      behaviour(d, "w.yaml"), ["check", "b.yaml"])[2], 2,
         ("w.yaml:", "error: YAML syntax error")),
    Case("labsim test: a link out of the folder", folder_link_out, 2,
         ("notes.yaml: error: is a symbolic link to a file outside",)),
    # replayed and plotted traces, checked row by row
    Case("--replay: event hoist=abc", lambda d: ["run", str(behaviour(d)), "--replay",
                                                 trace(d, set_cell(4, "events", "hoist=abc"))], 2,
         ("trace.csv:7:1: error: event 'hoist=abc': a slider's value 'abc' is not a number",)),
    Case("--replay: tick x1", lambda d: ["run", str(behaviour(d)), "--replay", trace(d, set_cell(0, "tick", "x1"))], 2,
         ("trace.csv:3:1: error: column 'tick' holds 'x1', not a whole number",)),
    Case("plot: x = 1e308", lambda d: ["plot", trace(d, set_cell(5, "x", "1e308")), "-o", "p.png"], 2,
         ("trace.csv:8:1: error: robot pioneer is at (1e+308,", "outside world 'walls_lab4'")),
    Case("plot: a time that is no number", lambda d: ["plot", trace(d, set_cell(2, "time", "soon")), "-o", "p.png"], 2,
         ("trace.csv:5:1: error: column 'time' holds 'soon', not a number",)),
    Case("plot: not a trace", lambda d: ((d / "t.csv").write_text(f"{SECRET}\n"), ["plot", "t.csv", "-o", "p.png"])[1],
         2, ("t.csv: error: not a labsim trace",)),
]


def _digests(folder: Path) -> dict[str, str]:
    return {str(p): hashlib.sha256(p.read_bytes()).hexdigest() for p in folder.rglob("*")
            if p.is_file() and not p.is_symlink() and os.access(p, os.R_OK)}


@pytest.mark.parametrize("case", cases(CASES, long={"trace of 2 GiB (sparse)"}))
def test_hostile_file(case: Case, tmp_path: Path) -> None:
    if not case.as_root_too and os.geteuid() == 0:
        pytest.skip("root may enter any folder")
    d = tmp_path / "case"
    d.mkdir()
    args = case.setup(d)
    before = _digests(d)

    def limits() -> None:
        if case.limit_file_bytes:
            signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a write past the limit fails, as on a full disk
            resource.setrlimit(resource.RLIMIT_FSIZE, (case.limit_file_bytes, case.limit_file_bytes))

    try:
        done = subprocess.run([sys.executable, "-m", "labsim", *args], cwd=d, capture_output=True, text=True,
                              timeout=TIMEOUT_S, preexec_fn=limits, stdin=subprocess.DEVNULL)
    finally:
        for p in d.rglob("*"):  # let pytest clean up a locked folder
            if p.is_dir() and not p.is_symlink():
                p.chmod(0o755)
    output = done.stdout + done.stderr
    assert done.returncode == case.code, output[-2000:]
    assert "Traceback" not in output, output[-2000:]
    assert len(output.encode()) <= MAX_OUTPUT
    for text in case.says:
        assert text in output, output[-2000:]
    for text in case.never:
        assert text not in output, output[-2000:]
    after = _digests(d)
    assert {k: v for k, v in after.items() if k in before} == before  # no input changed
    shutil.rmtree(tmp_path / "case", ignore_errors=True)
