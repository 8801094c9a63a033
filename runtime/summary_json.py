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

from labsim.foundation.files import check_output, write_output
from labsim.foundation.version import version
from labsim.runtime.result import RunResult

SCHEMA = "labsim-summary"
SCHEMA_VERSION = 2  # 2: log lines in 'logs', apart from 'warnings'; each robot's 'faults'


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


def summary_dict(result: RunResult) -> dict[str, Any]:
    """Every figure the text summary prints, as plain JSON-ready data (docs/summary-json.md)."""
    robots = {}
    for name, r in result.robots.items():
        robots[name] = {
            "mechanism": r.mechanism,
            "contacts": r.contacts,
            "contact_time_s": r.contact_time_s,
            "clamped_ticks": r.clamped_ticks,
            "wheel_limit_rad_s": None if r.wheel_limit_rad_s is None else number(r.wheel_limit_rad_s),
            "metrics": {m: number(v) for m, v in r.metrics.items()},
            "labels": dict(r.labels),
            "noise": dict(r.noise),
            "sonar_readings_lost": r.sonar_readings_lost,
            "faults": r.faults,
            "params": {k: v if isinstance(v, bool) else number(v) for k, v in r.params.items()},
        }
    rules = [{"id": rule.id, "text": rule.text, "ticks": rule.ticks} for rule in result.rules]
    return {
        "schema": SCHEMA,
        "version": SCHEMA_VERSION,
        "labsim": version(),
        "behaviour": {"name": result.name, "path": result.path, "sha256": result.sha256},
        "backend": result.backend,
        "world": result.world,
        "dt_s": result.dt_s,
        "seed": result.seed,
        "params": {k: number(v) for k, v in result.params.items()},
        "lists": {k: [[number(x) for x in v] if isinstance(v, tuple) else number(v) for v in value]
                  for k, value in result.lists.items()},
        "overridden": sorted(result.overridden),
        "ticks": result.ticks,
        "sim_time_s": result.sim_time_s,
        "wall_time_s": result.wall_time_s,
        "real_time_factor": number(result.real_time_factor),
        "stop_reason": result.stop_reason,
        "stopped_by": result.stopped_by,
        "stop_condition": result.stop_condition or None,
        "metrics": {m: a.value for m, a in result.metric_aggregates.items()},
        "metric_better": {m: b.value if b is not None else None for m, b in result.metric_better.items()},
        "robots": robots,
        "fleet": {m: number(v) for m, v in result.fleet.items()},
        "rules": rules,
        "idle_ticks": result.idle_ticks,
        "never_fired": result.never_fired,
        "faults": list(result.faults),
        "warnings": list(result.warnings),
        "logs": list(result.logs),
        "logs_unprinted": list(result.logs_unprinted),
        "trace": result.trace,
    }


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
