"""A run's summary as JSON: what ``labsim run --json`` writes and what each sweep row carries.

The text summary (runtime/cli/report.py) is for people; this is the same figures for programs,
versioned (``"schema": "labsim-summary"``, ``"version": SCHEMA_VERSION``) and documented in
docs/summary-json.md. JSON has no infinity or NaN (a sonar that sees nothing reads ``inf``;
``nan`` is a defined fault result), so non-finite numbers are written as the strings
``"inf"``, ``"-inf"`` and ``"nan"``; ``decode_number`` turns them back.
"""
from __future__ import annotations

import json
import math
import sys
from pathlib import Path
from typing import Any

from labsim import __version__
from labsim.foundation.diagnostics import Diagnostic
from labsim.foundation.files import check_output, write_output
from labsim.runtime.run import Run
from labsim.runtime.summary import Summary

SCHEMA = "labsim-summary"
SCHEMA_VERSION = 1


def number(value: float | int | bool) -> float | int | bool | str:
    """A number JSON can hold: non-finite floats become "inf", "-inf" or "nan"."""
    if isinstance(value, float) and not math.isfinite(value):
        return "nan" if value != value else ("inf" if value > 0 else "-inf")
    return value


def decode_number(value: Any) -> Any:
    """The inverse of ``number`` for one value: "inf", "-inf", "nan" become floats again."""
    if value in ("inf", "-inf", "nan"):
        return float(value)
    return value


def stop_reason(run: Run, summary: Summary) -> str:
    """Why the run ended: "stop condition", "interrupted" (Ctrl-C), "budget" or "max ticks"."""
    if summary.interrupted:
        return "interrupted"
    if summary.over_budget:
        return "budget"
    return "stop condition" if run.finished else "max ticks"


def summary_dict(summary: Summary, run: Run, *, warnings: list[str] | None = None) -> dict[str, Any]:
    """Every figure the text summary prints, as plain JSON-ready data.

    ``warnings`` are the runtime warnings the run emitted as it went (the compiler's warnings
    are added from the program).
    """
    p = run.program
    limits = {r.name: r.limit for r in run.robots}
    noisy = {r.name: r for r in run.noise.robots} if run.noise is not None else {}
    robots = {}
    for name, r in summary.robots.items():
        robots[name] = {
            "mechanism": bool(r["mechanism"]),
            "contacts": r["contacts"],
            "contact_time_s": r["contact_time_s"],
            "clamped_ticks": r["clamped_ticks"],
            "wheel_limit_rad_s": None if r["mechanism"] else number(limits[name]),
            "metrics": {m: number(v) for m, v in r["metrics"].items()},
            "labels": dict(r["labels"]),
            "noise": noisy[name].noise.header() if name in noisy else {},
            "sonar_readings_lost": noisy[name].dropped if name in noisy else 0,
        }
    rules = [{"id": rid, "text": summary.rule_labels[rid], "ticks": n} for rid, n in summary.rule_counts.items()]
    return {
        "schema": SCHEMA,
        "version": SCHEMA_VERSION,
        "labsim": __version__,
        "behaviour": {"name": p.name, "path": p.path, "sha256": p.sha256},
        "backend": summary.backend,
        "world": p.world.name,
        "dt_s": p.dt_s,
        "seed": p.seed,
        "params": {k: number(v) for k, v in p.params.items()},
        "overridden": sorted(p.overridden),
        "ticks": summary.ticks,
        "sim_time_s": summary.sim_time_s,
        "wall_time_s": summary.wall_time_s,
        "real_time_factor": number(summary.real_time_factor),
        "stop_reason": stop_reason(run, summary),
        "stopped_by": summary.stopped_by,
        "stop_condition": summary.stop_condition or None,
        "metrics": dict(zip(p.metric_names, (a.value for a in p.metric_aggregates))),
        "robots": robots,
        "fleet": {m: number(v) for m, v in summary.fleet.items()},
        "rules": rules,
        "idle_ticks": summary.idle_ticks,
        "never_fired": [rule["id"] for rule in rules if rule["ticks"] == 0],
        "faults": list(summary.faults),
        "warnings": [_warning_line(d) for d in p.warnings] + list(warnings or []),
        "trace": summary.trace,
    }


def _warning_line(d: Diagnostic) -> str:
    """A compiler warning on one line: ``path:line:col: warning: message``."""
    return d.format().splitlines()[0]


def dumps(data: dict[str, Any]) -> str:
    """The JSON text: indented, keys in the order above, no Infinity/NaN tokens."""
    return json.dumps(data, indent=2, allow_nan=False) + "\n"


def write(data: dict[str, Any], path: str | Path) -> None:
    """Written beside the target and renamed into place (foundation/files.py)."""
    write_output(path, dumps(data))


def emit_json(data: dict[str, Any], target: str) -> None:
    """Write to the file ``target``, or to standard output when it is ``-``."""
    if target == "-":
        sys.stdout.write(dumps(data))
        sys.stdout.flush()
    else:
        write(data, target)


def check_json_output(path: str, inputs: list[Path], option: str = "--json") -> None:
    """Refuse, before anything runs, a JSON output that would overwrite an input or cannot be written."""
    check_output(path, inputs, option)
