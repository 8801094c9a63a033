"""Golden traces: a stored trace that turns a behaviour into a regression test.

``behaviours/X.yaml`` is tested against ``behaviours/X.golden.csv``. ``compare`` walks both
traces row by row and stops at the first difference, which it reports the way a person
reads it: the tick, the robot, the column, expected against actual, the tolerance, and a few
ticks of context on either side.

Tolerance: numbers match when ``|actual - expected| <= ABS_TOL + REL_TOL * |expected|``
(inf matches inf, nan matches nan); text columns (robot, state, rule, events) must be equal.
The trace stores 6 significant digits, so the tolerance is the last digit's worth: enough to
absorb a different rounding of the same run, never a real change in behaviour.
"""
from __future__ import annotations

import math
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path

from labsim.backends import DEFAULT, load_backend
from labsim.foundation.diagnostics import Diagnostic, LabsimError
from labsim.foundation.files import check_output, read_input
from labsim.foundation.kinds import golden_path as golden_path  # the one rule for file kinds names goldens
from labsim.runtime.result import RunResult
from labsim.runtime.run import Behaviour, compile_behaviour
from labsim.runtime.trace import FOOTER, Trace, TraceFormatError, footer_of, parse_header, read_trace

ABS_TOL = 1e-6
REL_TOL = 1e-5
CONTEXT_BEFORE, CONTEXT_AFTER = 3, 2


def tolerance(expected: float) -> float:
    return ABS_TOL + REL_TOL * abs(expected)


def _number(text: str) -> float | None:
    try:
        return float(text)
    except ValueError:
        return None


def _same(expected: str, actual: str) -> bool:
    if expected == actual:
        return True
    e, a = _number(expected), _number(actual)
    if e is None or a is None:
        return False
    if math.isnan(e) or math.isnan(a) or math.isinf(e) or math.isinf(a):
        return (math.isnan(e) and math.isnan(a)) or e == a
    return abs(a - e) <= tolerance(e)


@dataclass(frozen=True)
class Difference:
    lines: list[str]

    def __str__(self) -> str:
        return "\n".join(self.lines)


def compare(expected: Trace, actual: Trace) -> Difference | None:
    """None when the traces agree within the tolerance; else the first difference, explained."""
    notes = []
    if expected.header.get("sha256") != actual.header.get("sha256"):
        notes.append("note: the behaviour file has changed since the golden was recorded")
    notes += _world_notes(expected.header, actual.header)
    before, after = expected.header.get("params") or {}, actual.header.get("params") or {}
    changed = [f"{k} {before.get(k, '(none)')} -> {after.get(k, '(none)')}"
               for k in sorted(set(before) | set(after)) if before.get(k) != after.get(k)]
    if changed:
        notes.append("note: parameters differ from the golden's: " + ", ".join(changed))
    if expected.columns != actual.columns:
        missing = [c for c in expected.columns if c not in actual.columns]
        extra = [c for c in actual.columns if c not in expected.columns]
        lines = ["the trace columns differ:"]
        if missing:
            lines.append(f"  only in the golden: {', '.join(missing)}")
        if extra:
            lines.append(f"  only in this run:   {', '.join(extra)}")
        if not missing and not extra:
            lines.append("  the same columns in another order")
        return Difference(lines + notes)
    cols = expected.columns
    for i, (erow, arow) in enumerate(zip(expected.rows, actual.rows)):
        for j, (e, a) in enumerate(zip(erow, arow)):
            if not _same(e, a):
                return Difference(_explain(expected, actual, i, j) + notes)
    if len(expected.rows) != len(actual.rows):
        last = lambda t: t.rows[-1][cols.index("tick")] if t.rows else "-"  # noqa: E731
        return Difference([f"the golden has {len(expected.rows)} rows (last tick {last(expected)}), "
                           f"this run {len(actual.rows)} (last tick {last(actual)}): the run stopped at "
                           "another tick"] + notes)
    return None


def _world_notes(expected: dict, actual: dict) -> list[str]:
    """Whether the world changed since the golden was recorded (goldens without a world hash say nothing)."""
    if expected.get("world") != actual.get("world"):
        return [f"note: the golden ran in world '{expected.get('world')}', this run in '{actual.get('world')}'"]
    if not expected.get("world_sha256") or expected.get("world_sha256") == actual.get("world_sha256"):
        return []
    note = f"note: world '{actual.get('world')}' has changed since the golden was recorded"
    if expected.get("world_version") != actual.get("world_version"):
        then, now = (h.get("world_version") or "a world file" for h in (expected, actual))
        note += f" ({then} then, {now} now)"
    return [note]


def _explain(expected: Trace, actual: Trace, i: int, j: int) -> list[str]:
    cols = expected.columns
    erow, arow = expected.rows[i], actual.rows[i]
    col = cols[j]
    e, a = erow[j], arow[j]
    where = f"tick {erow[cols.index('tick')]} (time {erow[cols.index('time')]} s), robot {erow[cols.index('robot')]}"
    lines = [f"first difference at {where}, column '{col}':"]
    en, an = _number(e), _number(a)
    if en is not None and an is not None and math.isfinite(en) and math.isfinite(an):
        lines.append(f"  expected {e}, actual {a}: off by {abs(an - en):.3g}, tolerance {tolerance(en):.3g} "
                     f"({ABS_TOL:g} + {REL_TOL:g} x |expected|)")
    else:
        lines.append(f"  expected {e!r}, actual {a!r} (must be equal)")
    show: list[str] = [c for c in ("tick", "time") if c in cols]
    for c in ("rule", col):
        if c not in show:
            show.append(c)
    table = [["", *show]]
    for k in range(max(0, i - CONTEXT_BEFORE), min(len(expected.rows), len(actual.rows), i + CONTEXT_AFTER + 1)):
        cells = [">" if k == i else ""]
        for c in show:
            x, y = expected.rows[k][cols.index(c)], actual.rows[k][cols.index(c)]
            cells.append(x if x == y else f"{x} | {y}")
        table.append(cells)
    widths = [max(len(r[n]) for r in table) for n in range(len(table[0]))]
    lines.append("  context (golden | this run where they differ):")
    lines += ["  " + "  ".join(cell.ljust(w) for cell, w in zip(r, widths)).rstrip() for r in table]
    return lines


@dataclass(frozen=True)
class Verdict:
    """One behaviour against its golden: passed or not, and the lines ``labsim test`` prints."""

    passed: bool
    lines: list[str]

    def __str__(self) -> str:
        return "\n".join(self.lines)


def check_golden(behaviour: str | Path, backend: str = DEFAULT, options: dict[str, object] | None = None,
                 *, record_with: str = "", shown_as: str | Path | None = None) -> Verdict:
    """Re-run a behaviour and compare its trace with its golden (``labsim test`` and the pytest
    plugin both report what this returns). ``record_with`` is the command that records a missing
    golden (default: ``labsim test FILE --update-goldens``); ``shown_as`` is the file's name in
    the text (default: the path as given). Raises LabsimError for a broken file."""
    compiled = compile_behaviour(behaviour)  # a broken file is reported as broken, not as missing its golden
    f = Path(shown_as if shown_as is not None else behaviour)
    golden = golden_path(f)
    if not golden_path(behaviour).exists():
        how = record_with or f"labsim test {f} --update-goldens"
        return Verdict(False, [f"FAIL {f}: no golden trace {golden}; record one with: {how}"])
    with tempfile.TemporaryDirectory() as d:
        actual = Path(d) / "actual.csv"
        record_trace(behaviour, actual, backend, options, compiled)
        try:
            if _same_rows(golden_path(behaviour), actual):
                return Verdict(True, [f"ok   {f}"])
            expected_trace = read_trace(golden_path(behaviour))
        except TraceFormatError as e:
            return Verdict(False, [f"FAIL {f}: {e}"])
        difference = compare(expected_trace, read_trace(actual))
    if difference is None:
        return Verdict(True, [f"ok   {f}"])
    return Verdict(False, [f"FAIL {f} (golden {golden})"] + ["  " + line for line in str(difference).splitlines()])


def _same_rows(golden: Path, actual: Path) -> bool:
    """Whether the golden's columns and rows are the run's, byte for byte: then ``compare`` finds
    no difference, whatever the headers say (their notes only explain a difference), and the two
    traces need not be parsed (a third of checking the wall lab's golden). The golden's header
    must still be one (else TraceFormatError, as ``read_trace`` says)."""
    try:
        expected = read_input(golden, "golden").decode("utf-8")
        ran = read_input(actual, "trace").decode("utf-8")
    except (LabsimError, UnicodeDecodeError):
        return False  # read_trace says what is wrong
    first, _, rows = expected.partition("\n")
    body, _ = footer_of(ran.partition("\n")[2])
    if rows != body:
        return False
    parse_header(golden, first, expected[:4096])
    return True


def record_golden(behaviour: str | Path, backend: str = DEFAULT,
                  options: dict[str, object] | None = None) -> tuple[Path, RunResult]:
    """Run a behaviour and store its trace as its golden, replacing the old one only once the
    run has finished (an interrupted run leaves the old golden as it was)."""
    golden = golden_path(behaviour)
    world = compile_behaviour(behaviour).program.world.source  # the run's other input
    check_output(golden, [behaviour, world])  # a golden that is a link to its behaviour is refused
    fd, tmp = tempfile.mkstemp(suffix=".csv", dir=golden.parent)
    os.close(fd)
    try:
        summary = record_trace(behaviour, tmp, backend, options)
        _drop_footer(tmp)
        os.chmod(tmp, 0o644)  # mkstemp makes it private; a golden is a shared file
        os.replace(tmp, golden)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return golden, summary


def _drop_footer(path: str | Path) -> None:
    """A golden is a finished run by construction, stored without the trace's ``# end`` line: the
    goldens recorded before traces had one stay byte-identical (docs/trace-format.md)."""
    data = read_input(path, "golden")
    body = data.rstrip(b"\n")
    cut = body.rfind(b"\n") + 1
    if body[cut:].startswith(FOOTER.encode()):
        Path(path).write_bytes(data[:cut])


def record_trace(behaviour: str | Path, trace_path: str | Path, backend: str = DEFAULT,
                 options: dict[str, object] | None = None, compiled: Behaviour | None = None) -> RunResult:
    """Run a behaviour as its file says (no overrides), writing its trace to trace_path
    (``compiled``: the file compiled already, as it is, when the caller has it)."""
    compiled = compiled if compiled is not None else compile_behaviour(behaviour)
    run = compiled.bind(load_backend(backend, **(options or {})), trace=trace_path)
    try:
        summary = run.run()
    finally:
        run.close()
    if summary.interrupted:
        raise KeyboardInterrupt
    if summary.over_budget:  # a run its budgets cut short is no golden of what the file does
        raise LabsimError([Diagnostic(str(behaviour), f"{summary.over_budget}; no golden recorded")])
    if run.trace_error is not None:
        raise run.trace_error
    return summary
