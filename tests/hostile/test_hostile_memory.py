"""Hostile memory and hostile data, as a table: each case is files and a command line, the exit
code, what the message must name, and the most memory the labsim process may take (its peak
resident set, read from the operating system when it ends). Image signals past the memory
budget, the operating system's cap as the backstop, alias bombs and deep nesting in the files
pictures read, and trace headers nested 100,000 deep. Every case runs as a user would, in a
process of its own; none prints a traceback or changes a file it was given.
"""
from __future__ import annotations

import os
import resource
import signal
import subprocess
import sys
import threading
from dataclasses import dataclass, field
from pathlib import Path

import pytest
from helpers import measured_command, measured_result

pytestmark = pytest.mark.slow  # every case is a labsim process of its own

TIMEOUT_S = 300  # generous: the machine is shared; a hang is what this catches, not slowness
MAX_OUTPUT = 20_000  # bytes of stdout + stderr any case may print
MB = 1024 * 1024


def images(n: int, side: int, kept: bool) -> str:
    """n signals ``invert(camera)`` at side x side pixels; ``kept``: a rule reads each, else none does."""
    lets = "".join(f"  i{k}: invert(camera)\n" for k in range(n))
    rules = "".join(f"  - if mean(i{k}) > 300 then wheels(0, 0)\n" for k in range(n)) if kept else ""
    return (f"labsim: 1\nworld: road_loop\nstop: time >= 0.1\nrobots:\n  r:\n    model: pioneer_p3dx\n"
            f"    at: spawn\n    camera: {{resolution: [{side}, {side}]}}\nlet:\n{lets}rules:\n{rules}"
            "  - else wheels(1, 1)\n")


GOOD = ("labsim: 1\nworld: walls_lab4\nstop: time >= 1\nrobots:\n  pioneer: {model: pioneer_p3dx, at: [0, 0, 0]}\n"
        "let:\n  s5: sonar5\nrules:\n  - always move(2)\n")
# 342 bytes that safe_load expands to 9**9 strings; labsim's reader stops at the first anchor
BOMB = 'a: &a ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]\n' + "".join(
    f"{chr(98 + i)}: &{chr(98 + i)} [{','.join(['*' + chr(97 + i)] * 9)}]\n" for i in range(8))
DEEP_YAML = "let: " + "[" * 100_000 + "]" * 100_000 + "\n"
DEEP_JSON = '{"a": ' + "[" * 100_000 + "]" * 100_000 + "}"


@dataclass
class Case:
    name: str
    args: list[str]  # after `labsim`
    code: int
    says: tuple[str, ...]  # in stdout + stderr, each
    files: dict[str, str] = field(default_factory=dict)  # name -> text, in a fresh folder
    max_rss_mb: int = 600  # the labsim process's peak resident set
    first: list[str] = field(default_factory=list)  # a command run before, whose outputs are the case's inputs
    address_space_mb: int = 0  # a cap the caller puts on the process (the system's), 0 for none


CASES = [
    # -- the memory budget: the checker's estimate, at the signal that tips it -------------------
    Case("100 image signals a rule reads, 2000 x 2000: refused at the one past 1,000 MB", ["check", "b.yaml"], 2,
         ("b.yaml:92:8: error: with signal 'i82' the images alive need more than this run's memory budget of "
          "1,000 MB", "--budget memory_mb=1212"), {"b.yaml": images(100, 2000, kept=True)}),
    Case("the same with run: refused before anything runs", ["run", "b.yaml", "-q"], 2,
         ("b.yaml:92:8: error: with signal 'i82'",), {"b.yaml": images(100, 2000, kept=True)}),
    Case("30 kept image signals under a budget of 300 MB", ["run", "b.yaml", "-q", "--budget", "memory_mb=300"], 2,
         ("b.yaml:34:8: error: with signal 'i24'", "--budget memory_mb=372"), {"b.yaml": images(30, 2000, kept=True)}),
    Case("30 kept image signals within the default budget run", ["run", "b.yaml", "-q"], 0, (),
         {"b.yaml": images(30, 2000, kept=True)}, max_rss_mb=900),
    # 300 of 2000 x 2000 (12 MB each, as the budget cases count them) would hold 3.6 GB if each
    # were kept, nine times the cap: 1000 showed the same at three times the CPU
    Case("300 image signals nothing reads, 2000 x 2000: each freed after its last use",
         ["run", "b.yaml", "-q"], 0, ("signal 'i0' is computed but never used",),
         {"b.yaml": images(300, 2000, kept=False)}, max_rss_mb=400),
    # -- the operating system's cap: what the estimate misses ends the run with labsim's message ---
    Case("a system cap below what the run needs", ["run", "b.yaml", "-q"], 2,
         ("b.yaml: error: the run ran out of memory after 0 ticks", "--budget memory_mb=N"),
         {"b.yaml": images(50, 2000, kept=True)}, address_space_mb=600),
    # -- every YAML a picture reads goes through the one safe reader -------------------------------
    Case("plot --signals of a trace whose behaviour became an alias bomb", ["plot", "t.csv", "--signals", "-o",
                                                                            "s.png"], 0,
         ("b.yaml:1:4: warning: YAML anchors (&a) are not supported", "the pictures are drawn without this file"),
         {"b.yaml": GOOD}, first=["run", "b.yaml", "--trace", "t.csv", "-q"]),
    Case("plot --signals of a trace whose behaviour nests 100,000 deep", ["plot", "t.csv", "--signals", "-o",
                                                                          "s.png"], 0,
         ("b.yaml:1:105: warning: YAML nested more than 100 levels deep",),
         {"b.yaml": GOOD}, first=["run", "b.yaml", "--trace", "t.csv", "-q"]),
    Case("check of an alias bomb", ["check", "b.yaml"], 2, ("b.yaml:1:4: error: YAML anchors (&a)",),
         {"b.yaml": BOMB}),
    # -- every JSON reader is depth-capped ----------------------------------------------------------
    Case("a trace header nested 100,000 deep", ["plot", "t.csv", "-o", "m.png"], 2,
         ("t.csv:1:1: error: damaged trace header: JSON nested more than 64 levels deep",),
         {"t.csv": "# labsim-trace " + DEEP_JSON + "\ntick,time,robot\n"}),
    Case("a replayed trace with a header nested 100,000 deep", ["run", "b.yaml", "--replay", "t.csv", "-q"], 2,
         ("damaged trace header: JSON nested more than 64 levels deep",),
         {"b.yaml": GOOD, "t.csv": "# labsim-trace " + DEEP_JSON + "\ntick,time,robot\n"}),
]

# the files the cases write: they may change, nothing else may
OUTPUTS = {"t.csv", "s.png", "m.png"}


def run_measured(args: list[str], cwd: Path, address_space_mb: int = 0) -> tuple[int, str, float]:
    """Run labsim; its exit code, its output, and its peak resident set in MB (wait4's rusage,
    taken by a small launcher: helpers.measured_command)."""
    def cap() -> None:
        if address_space_mb:
            resource.setrlimit(resource.RLIMIT_AS, (address_space_mb * MB, address_space_mb * MB))

    out_path = cwd.parent / f"{cwd.name}.out"  # outside the case's folder, whose files are checked
    report = cwd.parent / f"{cwd.name}.peak"
    with out_path.open("w+", encoding="utf-8") as out:
        proc = subprocess.Popen(measured_command(report, [sys.executable, "-m", "labsim", *args]), cwd=cwd,
                                stdout=out, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, preexec_fn=cap,
                                start_new_session=True)
        timer = threading.Timer(TIMEOUT_S, lambda: os.killpg(proc.pid, signal.SIGKILL))
        timer.start()
        try:
            proc.wait()
        finally:
            timer.cancel()
        out.seek(0)
        said = out.read()
    code, peak = measured_result(report)
    return code, said, peak


@pytest.mark.parametrize("case", CASES, ids=[c.name for c in CASES])
def test_hostile_memory(case: Case, tmp_path: Path) -> None:
    folder = tmp_path / "case"
    folder.mkdir()
    for name, text in case.files.items():
        (folder / name).write_text(text, encoding="utf-8")
    if case.first:
        code, said, _ = run_measured(case.first, folder)
        assert code == 0, said[-3000:]
        (folder / "b.yaml").write_text(BOMB if "alias" in case.name else DEEP_YAML, encoding="utf-8")
    before = {p.name: p.read_bytes() for p in folder.iterdir()}
    code, said, peak_mb = run_measured(case.args, folder, case.address_space_mb)
    assert "Traceback" not in said, said[-3000:]
    assert code == case.code, said[-3000:]
    for text in case.says:
        assert text in said, said[-3000:]
    assert len(said.encode()) <= MAX_OUTPUT, said[:3000]
    print(f"\n{case.name}: peak resident set {peak_mb:.0f} MB")
    assert peak_mb <= case.max_rss_mb, f"peak resident set {peak_mb:.0f} MB"
    for name, data in before.items():  # an input is never changed
        if name not in OUTPUTS:
            assert (folder / name).read_bytes() == data, name
    assert {p.name for p in folder.iterdir()} <= set(before) | OUTPUTS


WIDE = ("labsim: 1\nworld: walls_lab4\nstop: time >= 100000\nrobots:\n"
        "  g: {model: pioneer_p3dx, count: 50, at: random}\nlet:\n  a: sonar1 * 1.123456\n"
        "  b: sonar2 * 1.123456\n  c: sonar3 * 1.123456\nrules:\n  - always move(1)\n")


def test_a_trace_stops_within_a_row_of_its_budget(tmp_path: Path) -> None:
    # 50 robots write about 4,500 bytes a tick: checked every 256 ticks, a 1 MB budget let 1.15 MB through
    (tmp_path / "b.yaml").write_text(WIDE, encoding="utf-8")
    code, said, _ = run_measured(["run", "b.yaml", "--trace", "t.csv", "-q", "--budget", "trace_mb=1"], tmp_path)
    assert code == 2 and "Traceback" not in said, said[-3000:]
    assert "the trace t.csv reached its budget of 1 MB after" in said
    size = (tmp_path / "t.csv").stat().st_size
    assert 1_000_000 < size <= 1_000_000 + 1_000, size  # one row, and the footer
    assert (tmp_path / "t.csv").read_text(encoding="utf-8").splitlines()[-1].startswith('# end {"interrupted": true')
