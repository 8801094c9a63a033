"""Text from a hostile file reaches the teacher's terminal inert, and log output is bounded.

A table, as the other hostile suites: each case writes files in a fresh folder, runs ``labsim``
as a user would, and holds its output to docs/security.md ("What is shown"): every exact line
the case names is there, and no terminal control character (ESC, BEL, a C1 control) nor a bidi
override is, whatever the file put in its ``name:``, a log, a label, a parameter name or a source
line. Tab, newline and the carriage return labsim writes before a log line are labsim's own.
"""
from __future__ import annotations

import csv
import re
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

import pytest
from helpers import ROOT

from labsim.runtime.trace import read_trace

pytestmark = pytest.mark.slow  # every case is a labsim process of its own

TIMEOUT_S = 300  # generous: the machine is shared; a hang is what this catches, not slowness
RAW = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\x7f-\x9f\u202a-\u202e\u2066-\u2069]")  # never printed

HEAD = "labsim: 1\nworld: walls_lab4\nstop: time >= 1\n"
ROBOT = "robots:\n  p: {model: pioneer_p3dx, at: [0, 0, 0]}\n"
OSC52 = "\\e]52;c;aGk=\\a"  # set the clipboard, as YAML writes it in a double-quoted text
BIDI_LINE = '- always log("\u202e x"), move(nosuch)'  # an override before a mistake on its line


@dataclass(frozen=True)
class Case:
    name: str
    args: list[str]  # after `labsim`; the files are in the current folder
    code: int
    says: tuple[str, ...]  # exact lines (or parts of lines) of stdout + stderr
    files: dict[str, str | bytes] = field(default_factory=dict)


CASES = [
    Case("ESC and OSC 52 in name:", ["run", "b.yaml"], 0,
         ("a\\x1b[2J\\x1b]52;c;aGk=\\x07  (b.yaml, pymunk, seed 0)",),
         {"b.yaml": f'labsim: 1\nname: "a\\e[2J{OSC52}"\nworld: walls_lab4\nstop: time >= 1\n{ROBOT}'
                    "rules:\n  - always move(1)\n"}),
    Case("ESC in a log's text", ["run", "b.yaml"], 0,
         ("[0.00 s] p: red \\x1b[31m here \\u202e end",
          '  main:1  always move(1), log("red \\x1b[31m here \\u202e end")        20'),
         {"b.yaml": HEAD + ROBOT + 'rules:\n  - "always move(1), log(\\"red \\e[31m here \\u202e end\\")"\n'}),
    Case("OSC 52 in a label", ["run", "b.yaml"], 0,
         ("  label s: arm \\x1b]52;c;aGk=\\x07 0.5",),
         {"b.yaml": HEAD + ROBOT + f'sliders:\n  s: {{min: 0, max: 1, value: 0.5, label: "arm {OSC52} {{s}}"}}\n'
                    "rules:\n  - always move(1)\n"}),
    Case("OSC 52 in a parameter's name, quoted by a diagnostic", ["check", "b.yaml"], 2,
         ("b.yaml:4:10: error: 'a\\x1b]52;c;aGk=\\x07' is not a valid parameter name: use letters, digits and '_', "
          "starting with a letter",
          '    4 | params: {"a\\e]52;c;aGk=\\a": 1}',
          "      |          ^~~~~~~~~~~~~~~~~"),
         {"b.yaml": HEAD + f'params: {{"a{OSC52}": 1}}\n' + ROBOT + "rules:\n  - always move(1)\n"}),
    Case("a raw ESC in a source line, echoed with a caret", ["check", "b.yaml"], 2,
         ("b.yaml:4:8: error: a YAML file may not hold the control character U+001B",
          "    4 | name: a\\x1b[2Jb",
          "      |        ^~~~"),
         {"b.yaml": HEAD + "name: a\x1b[2Jb\n" + ROBOT + "rules:\n  - always move(1)\n"}),
    Case("a vertical tab and a NUL in a source line", ["check", "b.yaml"], 2,
         ("b.yaml:4:8: error: a YAML file may not hold the control character U+000B",
          "    4 | name: a\\x0bb\\x00",
          "      |        ^~~~"),
         {"b.yaml": HEAD + "name: a\x0bb\x00\n" + ROBOT + "rules:\n  - always move(1)\n"}),
    Case("a bidi override in a source line: the caret under it", ["check", "b.yaml"], 2,
         ("b.yaml:7:6: error: unexpected character '\\u202e'",
          "    7 | - if \\u202eq > nosuch then move(1)",
          "      |      ^~~~~~"),
         {"b.yaml": HEAD + ROBOT + "rules:\n- if \u202eq > nosuch then move(1)\n- else move(1)\n"}),
    Case("a bidi override before the mistake: the caret still under the mistake", ["check", "b.yaml"], 2,
         (f"b.yaml:7:{BIDI_LINE.index('nosuch') + 1}: error: unknown name 'nosuch'",
          '    7 | - always log("\\u202e x"), move(nosuch)',
          "      | " + " " * (BIDI_LINE.index("nosuch") + 5) + "^~~~~~"),
         {"b.yaml": HEAD + ROBOT + "rules:\n" + BIDI_LINE + "\n"}),
]


def _run(args: list[str], folder: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "labsim", *args], cwd=folder, capture_output=True,
                          text=True, timeout=TIMEOUT_S, stdin=subprocess.DEVNULL)


@pytest.mark.parametrize("case", CASES, ids=[c.name for c in CASES])
def test_file_text_is_shown_inert(case: Case, tmp_path: Path) -> None:
    for name, text in case.files.items():
        if isinstance(text, bytes):
            (tmp_path / name).write_bytes(text)
        else:
            (tmp_path / name).write_text(text, encoding="utf-8")
    proc = _run(case.args, tmp_path)
    said = proc.stdout + proc.stderr
    assert "Traceback" not in said, said[-3000:]
    assert proc.returncode == case.code, said[-3000:]
    lines = said.split("\n")
    for text in case.says:
        assert any(text in line for line in lines), f"{text!r} not in:\n{said[-3000:]}"
    assert not RAW.search(said), repr(RAW.search(said))


def test_a_sweep_csv_cell_is_inert_and_no_formula(tmp_path: Path) -> None:
    name = '=HYPERLINK(\\"http://x\\")\\e[2J'
    (tmp_path / "b.yaml").write_text(f'labsim: 1\nname: "{name}"\nworld: walls_lab4\nstop: time >= 1\n{ROBOT}'
                                     "rules:\n  - always move(1)\n", encoding="utf-8")
    proc = _run(["sweep", "b.yaml", "--seeds", "1-2", "-j", "1", "-o", "out.csv"], tmp_path)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    rows = list(csv.DictReader((tmp_path / "out.csv").open(encoding="utf-8", newline="")))
    assert [r["name"] for r in rows] == ["'=HYPERLINK(\"http://x\")\\x1b[2J"] * 2
    assert [r["seed"] for r in rows] == ["1", "2"]  # numbers stay numbers
    assert not RAW.search((tmp_path / "out.csv").read_text(encoding="utf-8"))


def _logs(n: int, text: str) -> str:
    """A behaviour of one rule with ``n`` logs, run 1 simulated second (20 ticks)."""
    acts = ", ".join(f'log("{text} {i}")' for i in range(n))
    return f"labsim: 1\nworld: walls_lab4\nstop: time >= 1\n{ROBOT}rules:\n  - always move(1), {acts}\n"


@pytest.mark.parametrize(("text", "printed", "unprinted", "at"), [
    ("line", 1000, 1500, "0.10"),  # the cap of lines: 500 logs a tick pass the rate of 5 a second each
    ("\u202e" * 600, 333, 2167, "0.00"),  # the cap of bytes: each line cut to 500 characters, 3000 bytes inert
])
def test_500_logs_in_one_rule_print_a_bounded_amount(tmp_path: Path, text: str, printed: int,
                                                     unprinted: int, at: str) -> None:
    (tmp_path / "b.yaml").write_text(_logs(500, text), encoding="utf-8")
    proc = _run(["run", "b.yaml", "--trace", "t.csv"], tmp_path)
    assert proc.returncode == 0, proc.stderr[-3000:]
    # text mode reads labsim's "\r" before a log line as a line end of its own
    log_lines = [line for line in proc.stderr.split("\n") if line.startswith("[")]
    assert len(log_lines) == printed + 1  # and the note that the cap was reached
    assert log_lines[-1] == (f"[{at} s] no more log lines are printed in this run (at most 1,000 lines and 1 MB); "
                             "the summary counts the rest")
    assert len(proc.stderr.encode()) <= 1_000_000 + 200
    assert len(proc.stdout.encode()) <= 10_000  # the summary: 500 logs on one line are one entry
    assert f"logs: {printed} lines printed" in proc.stdout.split("\n")
    assert (f"  {unprinted} more lines not printed: no more log lines are printed in this run (at most 1,000 lines "
            "and 1 MB); the trace has them all") in proc.stdout.split("\n")
    assert "  log on line 7: 7500 lines not printed (at most 5 a simulated second; the trace has them all)" \
        in proc.stdout.split("\n")
    trace = read_trace(tmp_path / "t.csv")  # labsim reads back the trace it wrote
    events = trace.rows[1][-1].split(";")  # the trace keeps every log's event, each cut to 500 characters
    assert max(len(e) for e in events) <= len("log: ") + 500 * 6 and len(trace.rows[1][-1]) <= 100_100
    if len(text) < 100:
        assert len(events) == 500
    else:  # past 100,000 characters of log text in a tick, the rest are counted
        assert events[-1] == f"log: ... ({501 - len(events)} more logs this tick)"


def test_the_page_inserts_file_text_as_text() -> None:
    """The live view's page: innerHTML only ever gets a literal without a ${} field; names, labels
    and diagnostics go in through textContent."""
    static = ROOT / "runtime" / "view" / "static"
    for path in static.glob("*.js"):
        for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            for m in re.finditer(r"(innerHTML|outerHTML)\s*=\s*(.*?);", line):
                value = m.group(2).strip()
                assert value[:1] in "\"'`" and value[-1:] == value[:1] and "${" not in value, f"{path.name}:{n}"
            assert "insertAdjacentHTML" not in line and "document.write" not in line, f"{path.name}:{n}"
