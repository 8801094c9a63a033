"""What ``labsim grade`` writes that is data: the gradebook (CSV and JSON), the LMS file, the cache.

The fourth stage, beside the pages (runtime/grade/pages.py): every ``Grade`` becomes one row of
``gradebook.csv`` (score, status, reason, each criterion's pass or fail, each metric's mean,
messages; every cell through ``labsim.foundation.inert.spreadsheet_cell``, so a student's text
never becomes a formula), one entry of ``gradebook.json``, and one row of ``canvas.csv`` (the
columns Canvas's grade import reads; Moodle's import maps ``gradebook.csv``'s columns itself:
docs/grading.md). The cache keeps each finished submission's runs under its key (content hash
+ labsim version + assignment hash, runtime/grade/contract.py), so a second grading runs only
what changed. Everything goes out the one way out, ``labsim.foundation.files``.
"""
from __future__ import annotations

import base64
import csv
import hashlib
import io
import json
import math
from dataclasses import asdict
from pathlib import Path
from typing import Any

from labsim.foundation.diagnostics import Diagnostic, LabsimError, diagnostic_dict
from labsim.foundation.files import read_text, write_output
from labsim.foundation.inert import spreadsheet_cell
from labsim.runtime.grade.assignment import Assignment
from labsim.runtime.grade.runs import RAN, SeedRun
from labsim.runtime.grade.score import Grade

FORMAT = "labsim-gradebook/1"
# 2: a run keeps its pictures, no longer its trace; 3: measured metrics; 4: their faults apart, the
# stopping tick folded whatever the file's format version
CACHE_FORMAT = "labsim-grade-cache/4"


def _number(value: float | None, digits: int = 6) -> float | None:
    """A number for JSON and CSV: rounded, and None (an empty cell, null) when not finite."""
    if value is None or not math.isfinite(value):
        return None
    return round(value, digits)


def csv_rows(grades: list[Grade], assignment: Assignment, feedback_url: str = "",
             pages: bool = True) -> list[list[object]]:
    """The gradebook: a header, then one row per student; ``feedback_url`` leads each page's
    link (where the teacher puts the ``feedback`` folder online), else the link is relative;
    without ``pages`` (--no-pages) the Feedback column is empty: it links no page never written."""
    header: list[object] = ["Student", "Score", "Status", "Reason", "Feedback"]
    header += [f"pass {c.name}" for c in assignment.criteria]
    header += [f"mean {m}" for m in assignment.measured]
    header += [f"mean {m}" + (" (student's)" if m in assignment.measured else "") for m in assignment.metrics]
    header += ["Messages"]
    rows: list[list[object]] = [header]
    names = page_names([g.student for g in grades])
    for g in grades:
        passed = {r.name: ("pass" if r.passed else "fail") for r in g.criteria}
        link = f"{feedback_url}feedback/{names[g.student]}" if pages else ""
        row: list[object] = [g.student, _number(g.score, 2), g.status, g.reason, link]
        row += [passed.get(c.name, "") for c in assignment.criteria]
        row += [_number(g.measured.get(m)) for m in assignment.measured]
        row += [_number(g.means.get(m)) for m in assignment.metrics]
        row += [" | ".join(messages(g))]
        rows.append(row)
    return rows


def canvas_rows(grades: list[Grade], assignment: Assignment, feedback_url: str = "",
                pages: bool = True) -> list[list[object]]:
    """Canvas's grade import: Student, ID, SIS User ID, SIS Login ID, Section, then the
    assignment's column; the student's name goes in SIS Login ID, which Canvas matches on. With
    ``feedback_url``, a ``Notes`` column (Canvas's own notes column, which its import fills when
    the gradebook shows it) holds each page's absolute link."""
    header: list[object] = ["Student", "ID", "SIS User ID", "SIS Login ID", "Section", assignment.title]
    names = page_names([g.student for g in grades])
    notes = bool(feedback_url) and pages
    rows: list[list[object]] = [header + (["Notes"] if notes else [])]
    for g in grades:
        row: list[object] = [g.student, "", "", g.student, "", _number(g.score, 2)]
        rows.append(row + ([f"{feedback_url}feedback/{names[g.student]}"] if notes else []))
    return rows


def csv_text(rows: list[list[object]]) -> str:
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    for row in rows:
        writer.writerow(["" if v is None else spreadsheet_cell(v) for v in row])
    return out.getvalue()


def messages(g: Grade) -> list[str]:
    """What the student should read first: faults and warnings of the runs, once each."""
    out: list[str] = []
    for r in g.runs:
        out += [f"fault: {f}" for f in r.faults]
        for w in r.warnings:  # the first line: the caret is on the page; "warning:" once
            first = w.splitlines()[0] if w else w
            out.append(first if "warning: " in first else f"warning: {first}")
    return list(dict.fromkeys(out))[:10]


def page_names(students: list[str]) -> dict[str, str]:
    """Each student's feedback page's file name (``NAME.html``; its pictures take ``NAME.png``
    and ``NAME.gif``): the id with anything but letters, digits, '-', '_' and '.' replaced, so
    that no name reaches outside the folder, and a short hash of the id added wherever that
    changed it or two names would be one file on a disk blind to case, so that no two students
    ever share a page (``a b`` and ``a_b``, ``.c`` and ``c``, ``Bob`` and ``bob``)."""
    safe = {s: "".join(ch if ch.isascii() and (ch.isalnum() or ch in "-_.") else "_" for ch in s).lstrip(".")
            for s in students}
    counts: dict[str, int] = {}
    for name in safe.values():
        counts[name.casefold()] = counts.get(name.casefold(), 0) + 1
    out = {}
    for student, name in safe.items():
        if name != student or counts[name.casefold()] > 1 or not name:
            name = f"{name or 'student'}-{hashlib.sha256(student.encode()).hexdigest()[:8]}"
        out[student] = f"{name}.html"
    return out


def grade_dict(g: Grade) -> dict[str, Any]:
    """A grade as JSON: no wall times, no traces (the same class grades to the same JSON)."""
    return {"student": g.student, "path": g.path, "status": g.status, "reason": g.reason,
            "score": _number(g.score, 2),
            "gate": g.gate or None,
            "criteria": [{"name": r.name, "description": r.description, "value": _number(r.value),
                          "passed": r.passed, "points": _number(r.points), "weight": r.weight,
                          "required": r.required, "from": r.source, "why": r.why} for r in g.criteria],
            "means": {k: _number(v) for k, v in g.means.items()},
            "measured": {k: _number(v) for k, v in g.measured.items()},
            "runs": [{"seed": r.seed, "status": r.status, "message": r.message, "stopped": r.stopped,
                      "metrics": {k: _number(v) for k, v in r.metrics.items()},
                      "measured": {k: _number(v) for k, v in r.measured.items()},
                      "distance_m": _number(r.distance_m), "faults": list(r.faults),
                      "measure_faults": list(r.measure_faults),
                      "collisions": r.collisions, "ticks": r.ticks, "never_fired": list(r.never_fired)}
                     for r in g.runs],
            "diagnostics": [diagnostic_dict(d) for d in g.diagnostics],
            "messages": messages(g)}


def gradebook_json(grades: list[Grade], assignment: Assignment, copies: list[tuple[str, tuple[str, ...]]],
                   reference: Grade | None, collisions: list[tuple[str, ...]] | None = None,
                   skipped: list[tuple[str, str]] | None = None, warnings: list[str] | None = None) -> str:
    counts: dict[str, int] = {}
    for g in grades:
        counts[g.status] = counts.get(g.status, 0) + 1
    data = {"format": FORMAT, "assignment": {"title": assignment.title, "path": assignment.path,
                                             "seeds": list(assignment.seeds),
                                             "criteria": [c.describe() for c in assignment.criteria],
                                             "measure": {m: assignment.definition(m) for m in assignment.measured},
                                             "gate_score": assignment.gate_score},
            "counts": counts, "students": [grade_dict(g) for g in grades],
            "likely_copies": [{"why": why, "students": list(students)} for why, students in copies],
            "name_collisions": [list(group) for group in collisions or []],
            "passed_over": [{"path": path, "why": why} for path, why in skipped or []],
            "assignment_warnings": list(warnings or []),
            "reference": grade_dict(reference) if reference is not None else None}
    return json.dumps(data, indent=2, ensure_ascii=False, allow_nan=False) + "\n"


def write_gradebook(out: Path, grades: list[Grade], assignment: Assignment,
                    copies: list[tuple[str, tuple[str, ...]]], reference: Grade | None,
                    inputs: list[str], feedback_url: str = "",
                    collisions: list[tuple[str, ...]] | None = None, skipped: list[tuple[str, str]] | None = None,
                    warnings: list[str] | None = None, pages: bool = True) -> list[Path]:
    written = [out / "gradebook.csv", out / "gradebook.json", out / "canvas.csv"]
    write_output(written[0], csv_text(csv_rows(grades, assignment, feedback_url, pages)), inputs, "--out")
    write_output(written[1], gradebook_json(grades, assignment, copies, reference, collisions or [], skipped, warnings),
                 inputs,
                 "--out")
    write_output(written[2], csv_text(canvas_rows(grades, assignment, feedback_url, pages)), inputs, "--out")
    return written


# -- the cache ---------------------------------------------------------------------------------

def _run_dict(r: SeedRun) -> dict[str, Any]:
    out = asdict(r)
    out["metrics"] = {k: (v if math.isfinite(v) else repr(v)) for k, v in r.metrics.items()}
    out["measured"] = {k: (v if math.isfinite(v) else repr(v)) for k, v in r.measured.items()}
    out["diagnostics"] = [asdict(d) for d in r.diagnostics]
    out["map_png"] = base64.b64encode(r.map_png).decode()
    out["animation_gif"] = base64.b64encode(r.animation_gif).decode()
    return out


def _run_of(d: dict[str, Any]) -> SeedRun:
    d = dict(d)
    d["metrics"] = {k: float(v) for k, v in d["metrics"].items()}
    d["measured"] = {k: float(v) for k, v in d["measured"].items()}
    d["diagnostics"] = tuple(Diagnostic(**{**x, "notes": tuple(x["notes"])}) for x in d["diagnostics"])
    d["map_png"] = base64.b64decode(d["map_png"])
    d["animation_gif"] = base64.b64decode(d["animation_gif"])
    for name in ("faults", "warnings", "logs", "never_fired", "measure_faults"):
        d[name] = tuple(d[name])
    return SeedRun(**d)


def cacheable(runs: list[SeedRun]) -> bool:
    """Runs worth keeping: each ran or stopped for a reason of its own (a timeout or a dead
    worker may be the machine's, so it is tried again)."""
    return all(r.status in (RAN, "budget stop", "compile error") for r in runs)


def save_cached(folder: Path, key: str, runs: list[SeedRun]) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    write_output(folder / f"{key}.json", json.dumps({"format": CACHE_FORMAT, "runs": [_run_dict(r) for r in runs]}))


def load_cached(folder: Path, key: str, seeds: tuple[int, ...]) -> list[SeedRun] | None:
    """The cached runs of a submission, or None (none kept, or a cache file that does not read)."""
    path = folder / f"{key}.json"
    if not key or not path.is_file():
        return None
    try:
        data = json.loads(read_text(path, "cache"))
        runs = [_run_of(r) for r in data["runs"]] if data.get("format") == CACHE_FORMAT else []
    except (LabsimError, ValueError, KeyError, TypeError):
        return None
    return runs if tuple(r.seed for r in runs) == seeds else None
