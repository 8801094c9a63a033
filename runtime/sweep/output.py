"""What a sweep shows and writes: the progress bar, the comparison table, the CSV and JSON files.

The rows come from runtime/sweep/grid.py, the figures of the table from runtime/sweep/stats.py; the
chart is runtime/sweep/plot.py. The JSON file's schema is in docs/sweep.md. File names, names and
messages are shown inert in the table and are inert spreadsheet cells in the CSV
(foundation/inert.py): a class's files are a student's text.
"""
from __future__ import annotations

import csv
import io
import json
import math
import sys
import time as clock
from pathlib import Path
from typing import Any, TextIO

from labsim.dsl.library.builtins import Better
from labsim.foundation.files import write_output
from labsim.foundation.inert import inert, spreadsheet_cell
from labsim.foundation.progress import StatusLine, bar
from labsim.foundation.version import version
from labsim.runtime.summary_json import number, summary_dict
from labsim.runtime.sweep.grid import STATUSES, Columns, Row, flat
from labsim.runtime.sweep.stats import Stat, Test

SWEEP_SCHEMA = "labsim-sweep"
SWEEP_VERSION = 1


class SweepProgress:
    """``[#####     ] 12/40 runs, 1 failed, ETA 0:23`` on one terminal line."""

    def __init__(self, total: int, stream: TextIO = sys.stderr, show: bool = True):
        self.total, self.show = total, show
        self.done = self.failed = 0
        self.line = StatusLine(stream, every_s=0.0)

    def update(self, row: Row) -> None:
        self.done += 1
        self.failed += row.failed
        if not self.show:
            return
        elapsed = clock.perf_counter() - self.line.started
        eta = elapsed / self.done * (self.total - self.done)
        failed = f", {self.failed} failed" if self.failed else ""
        self.line.draw(f"  {bar(self.done / max(self.total, 1))} {self.done}/{self.total} runs{failed}, "
                       f"ETA {_clock(eta)}   ")

    def clear(self) -> None:
        self.line.clear()


def _clock(seconds: float) -> str:
    whole = round(seconds)
    h, rest = divmod(whole, 3600)
    return f"{h}:{rest // 60:02d}:{rest % 60:02d}" if h else f"{rest // 60}:{rest % 60:02d}"


# -- the table --------------------------------------------------------------------------------

def _num(v: float) -> str:
    if isinstance(v, float) and math.isnan(v):
        return "-"
    return f"{v:.4g}"


def format_comparison(comp: dict[str, Any], aggregates: dict[str, str], several_files: bool = False) -> str:
    """Per metric: a line per group (n, mean, sd, 95% CI, min, max, the best marked), then the tests."""
    lines: list[str] = []
    for m in comp["metrics"]:
        entries: list[tuple[Any, Stat]] = comp["table"][m]
        better: Better | None = comp["better"].get(m)
        kind = aggregates.get(m, "")
        lines.append(f"{m}  ({kind + '; ' if kind else ''}{_goal(better, m in comp['disagree'])})")
        header = ["file" if several_files else "", "setting", "n", "mean", "sd", "95% CI", "min", "max", ""]
        body = []
        for i, (g, s) in enumerate(entries):
            ci = f"[{_num(s.ci_low)}, {_num(s.ci_high)}]" if s.n > 1 else "-"
            best = better is not None and i in comp["best"].get(m, []) and len(entries) > 1
            mark = f"best ({better.value})" if best and better is not None else ""
            if s.left_out:
                mark += f" ({s.left_out} non-finite left out)"
            body.append([inert(g.file) if several_files else "", inert(g.label) or "(as in the file)", str(s.n),
                         _num(s.mean), _num(s.sd), ci, _num(s.min), _num(s.max), mark.strip()])
        keep = [i for i in range(len(header)) if i != 0 or several_files]
        widths = {i: max(len(r[i]) for r in [header, *body]) for i in keep}
        for r in [header, *body]:
            cells = [r[i].ljust(widths[i]) if i in (0, 1, 8) else r[i].rjust(widths[i]) for i in keep]
            lines.append(("  " + "  ".join(cells)).rstrip())
        lines += [f"  {inert(_test_line(t, several_files))}" for t in comp["tests"] if t.metric == m]
        if better is None and len(entries) > 1 and m in comp["disagree"]:
            lines.append(f"  no best marked: give '{m}' the same 'better:' in every file, or pass --maximize {m}")
        elif better is None and len(entries) > 1:
            lines.append(f"  no best marked: to mark one, say which way is better in the file, "
                         f"{m}: {{value: ..., better: higher}} (or lower), or pass --maximize {m}")
        lines.append("")
    failed = [g for g in comp["groups"] if g.failed]
    for g in failed:
        where = inert(f"{g.file} ") if several_files else ""
        lines.append(f"{where}{inert(g.label) or '(as in the file)'}: {g.failed} of {g.runs} runs failed (not counted)")
    if any(not math.isnan(x.p) for x in comp["tests"]):  # a test was made, not only "too few runs"
        lines.append("test: Welch's t-test of the two means, two-sided; a difference is larger than the seeds' "
                     "noise when p < 0.05")
    return "\n".join(lines).rstrip()


def _goal(better: Better | None, disagree: bool) -> str:
    if better is not None:
        return f"{better.value} is better"
    return "the files say different ways are better" if disagree else "declares no direction"


def _test_line(t: Test, several_files: bool) -> str:
    where = f"{t.file}: " if several_files else ""
    if math.isnan(t.difference):
        return f"{where}{t.b} vs {t.a}: {t.verdict}"
    if math.isnan(t.p):  # no spread in either: nothing to test
        return f"{where}{t.b} vs {t.a}: {t.difference:+.4g}: {t.verdict}"
    p = f"p = {t.p:.2g}" if t.p >= 1e-4 else "p < 0.0001"
    return f"{where}{t.b} vs {t.a}: {t.difference:+.4g} (Welch's t-test, {p}): {t.verdict}"


def status_counts(rows: list[Row]) -> str:
    """``40 runs: 38 ok, 1 compile error, 1 timeout``."""
    counts = {s: sum(r.status == s for r in rows) for s in STATUSES}
    parts = [f"{n} {s}" for s, n in counts.items() if n]
    return f"{len(rows)} run{'s' if len(rows) != 1 else ''}: " + ", ".join(parts)


def failures(rows: list[Row], limit: int = 20) -> list[str]:
    """The failed rows, one line each (the first ``limit``)."""
    bad = [r for r in rows if r.failed]
    out = [inert(f"  {r.task.file} {r.task.label} seed {r.task.seed}: {r.status}: {r.message}")
           .replace("  seed", " seed") for r in bad[:limit]]
    if len(bad) > limit:
        out.append(f"  ... and {len(bad) - limit} more (all are in the results file)")
    return out


# -- files ------------------------------------------------------------------------------------

def columns(rows: list[Row], settings: list[str]) -> Columns:
    cols = Columns(settings=list(settings))
    for r in rows:
        if r.result is not None:
            cols.metrics += [m for m in r.result.metric_aggregates if m not in cols.metrics]
    return cols


def write_csv(rows: list[Row], path: str | Path, settings: list[str]) -> None:
    cols = columns(rows, settings)
    f = io.StringIO(newline="")
    writer = csv.DictWriter(f, fieldnames=cols.names(), extrasaction="ignore", restval="")
    writer.writeheader()
    for r in rows:
        writer.writerow({k: spreadsheet_cell(v) for k, v in flat(r).items()})
    write_output(path, f.getvalue())  # beside the target, renamed into place (foundation/files.py)


def sweep_json(rows: list[Row], comp: dict[str, Any], meta: dict[str, Any]) -> dict[str, Any]:
    """The whole sweep as JSON: what was asked, a row per run (with its summary), the comparison."""
    out_rows = [{"index": r.task.index, "file": r.task.file, "settings": dict(r.task.settings), "seed": r.task.seed,
                 "status": r.status, "message": r.message, "task_time_s": r.task_time_s, "worker": r.worker,
                 "retries": r.retries, "trace": r.task.trace if r.result is not None else None,
                 "summary": summary_dict(r.result) if r.result is not None else None} for r in rows]
    table = []
    for m in comp["metrics"]:
        better: Better | None = comp["better"].get(m)
        for i, (g, s) in enumerate(comp["table"][m]):
            table.append({"metric": m, "file": g.file, "settings": g.label, "n": s.n, "mean": number(s.mean),
                          "sd": number(s.sd), "ci95": [number(s.ci_low), number(s.ci_high)], "min": number(s.min),
                          "max": number(s.max), "best": i in comp["best"].get(m, []),
                          "better": better.value if better is not None else None})
    tests = [{"file": t.file, "metric": t.metric, "a": t.a, "b": t.b, "difference": number(t.difference),
              "test": "welch-t", "p": number(t.p), "verdict": t.verdict} for t in comp["tests"]]
    return {"schema": SWEEP_SCHEMA, "version": SWEEP_VERSION, "labsim": version(), **meta,
            "rows": out_rows, "comparison": table, "tests": tests}


def write_json(data: dict[str, Any], path: str | Path) -> None:
    text = json.dumps(data, indent=1, allow_nan=False) + "\n"
    if str(path) == "-":
        sys.stdout.write(text)
    else:
        write_output(path, text)
