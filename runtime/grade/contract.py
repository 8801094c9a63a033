"""A submission against the assignment's contract, before anything of it runs.

The second stage of ``labsim grade``: each submission (a behaviour file, or a folder holding
one) is compiled as the student wrote it, with every diagnostic kept, and then held to the
assignment: its world, its number of robots, the params the grader sets (each must be
declared, and take the grader's value) and the metrics the criteria read. What fails here is
that student's row with its reason — ``hostile file`` (the one way in refused it), ``budget
stop`` (too many robots, camera pixels, ...), ``compile error`` (all its diagnostics) or
``contract mismatch`` (what is missing, with the closest name the file has) — and never stops
the batch. A submission that passes becomes a ``Submission`` the driver makes jobs of.
"""
from __future__ import annotations

import hashlib
import os
import re
from collections.abc import Iterable
from dataclasses import dataclass, replace
from pathlib import Path

from labsim import __version__
from labsim.backends.scene.world_names import builtin_name
from labsim.dsl.emit.program import Program
from labsim.foundation.diagnostics import Diagnostic, LabsimError, did_you_mean
from labsim.foundation.files import read_input
from labsim.foundation.kinds import YAML_SUFFIXES, file_kind
from labsim.runtime.grade.assignment import Assignment
from labsim.runtime.run import compile_behaviour

# a student's status: graded, or why not
GRADED, MISMATCH, COMPILE_ERROR, HOSTILE = "graded", "contract mismatch", "compile error", "hostile file"
# INTERRUPTED: a signal (Ctrl-C, SIGTERM, SIGHUP) stopped the grading before its runs were done
TIMEOUT, BUDGET, CRASH, INTERRUPTED = "timeout", "budget stop", "crash", "interrupted"
STATUSES = (GRADED, MISMATCH, COMPILE_ERROR, HOSTILE, TIMEOUT, BUDGET, CRASH, INTERRUPTED)


@dataclass(frozen=True)
class Submission:
    """One student's submission: where it is, what it holds, and what the contract found."""

    student: str  # the file's stem, or the folder's name
    path: str  # the behaviour file
    key: str  # content hash + labsim version + assignment hash: the cache's key
    source: str  # the file's text, normalised (comments and spacing gone): likely copies share it
    status: str = GRADED  # GRADED when it met the contract (and may run)
    reason: str = ""
    diagnostics: tuple[Diagnostic, ...] = ()  # every diagnostic of the file, warnings too
    world_file: str | None = None  # a world file beside it (None: a built-in world)


def find_submissions(paths: list[str]) -> list[tuple[str, Path | None, str]]:
    """(student, behaviour file or None, why not) for each argument: a behaviour file; a folder
    of behaviour files (one student each; world and assignment files beside them are skipped);
    or a folder of folders, one per student, each holding one behaviour file."""
    out: list[tuple[str, Path | None, str]] = []
    missing = [Diagnostic(str(arg), "no such file or folder") for arg in map(Path, paths) if not os.path.lexists(arg)]
    if missing:  # a mistake on the command line, not a student's
        raise LabsimError(missing)
    for arg in map(Path, paths):
        if not arg.is_dir():
            out.append((arg.stem, arg, ""))
            continue
        files = sorted(p for p in arg.iterdir() if p.suffix in YAML_SUFFIXES and not p.is_dir())
        folders = sorted(p for p in arg.iterdir() if p.is_dir())
        if folders and not files:
            out += [_one_folder(f) for f in folders]
        else:
            out += [(p.stem, p, "") for p in files if file_kind(p) not in ("world", "assignment")]
    return out


def _behaviours(files: list[Path]) -> list[Path]:
    return [p for p in files if file_kind(p) == "behaviour"]


def _one_folder(folder: Path) -> tuple[str, Path | None, str]:
    found = _behaviours(sorted(p for p in folder.iterdir() if p.suffix in YAML_SUFFIXES))
    if len(found) != 1:
        return folder.name, None, (f"the folder {folder} holds {len(found)} behaviour files; a student's folder "
                                   "holds one")
    return folder.name, found[0], ""


def key_of(data: bytes, assignment: Assignment) -> str:
    digest = hashlib.sha256(data + b"\0" + __version__.encode() + b"\0" + assignment.sha256.encode())
    return digest.hexdigest()


def normalised(text: str) -> str:
    """The source with comments, blank lines and spacing gone: what a copy keeps."""
    lines = (re.sub(r"\s+#.*$|^#.*$", "", line) for line in text.splitlines())
    return "\n".join(re.sub(r"\s+", " ", line).strip() for line in lines if line.strip(" #\t"))


def check_submission(student: str, path: Path, assignment: Assignment) -> Submission:
    """Compile the submission as written and hold it to the contract; see the module docstring."""
    try:
        data = read_input(path, "behaviour")
    except LabsimError as e:
        return Submission(student, str(path), "", "", HOSTILE, _first(e.diagnostics), tuple(e.diagnostics))
    key = key_of(data, assignment)
    source = normalised(data.decode("utf-8", "replace"))
    base = Submission(student, str(path), key, source)
    try:
        program = compile_behaviour(path, budgets=assignment.budgets).program
    except LabsimError as e:
        status = classify(e.diagnostics)
        return _refused(base, status, _first(e.diagnostics), e.diagnostics)
    problems = contract_problems(program, assignment)
    world_file = None if builtin_name(program.world.source) else program.world.source
    if world_file is not None and not _inside(Path(world_file), path.parent):
        problems.append(f"its world file {world_file} is not in the submission's folder")
    if problems:
        return _refused(base, MISMATCH, "; ".join(problems), program.warnings)
    if world_file is not None:  # a changed world file is a changed submission: it is graded anew
        try:
            key = key_of(data + b"\0" + read_input(world_file, "world"), assignment)
        except LabsimError as e:
            return _refused(base, HOSTILE, _first(e.diagnostics), e.diagnostics)
    return Submission(student, str(path), key, source, GRADED, "", tuple(program.warnings), world_file)


def _refused(base: Submission, status: str, reason: str, diagnostics: Iterable[Diagnostic]) -> Submission:
    return replace(base, status=status, reason=reason, diagnostics=tuple(diagnostics))


def _inside(path: Path, folder: Path) -> bool:
    try:
        path.resolve().relative_to(folder.resolve())
    except ValueError:
        return False
    return True


def contract_problems(program: Program, assignment: Assignment) -> list[str]:
    """What the compiled program lacks of the contract, one phrase each ([] when it meets it)."""
    params, metrics, world = dict(program.params), program.metric_names, program.world
    robots = sum(g.count for g in program.robots)
    out = []
    for name in assignment.params:
        if name not in params:
            out.append(f"missing param '{name}'{did_you_mean(name, params)}")
    for name in assignment.metrics:
        if name not in metrics:
            out.append(f"missing metric '{name}'{did_you_mean(name, metrics)}")
    if assignment.world is not None and assignment.world not in (world.name, Path(world.source).stem):
        out.append(f"it uses the world '{world.name}', not '{assignment.world}'")
    if assignment.robots is not None and robots != assignment.robots:
        out.append(f"it runs {robots} robot{'s' * (robots != 1)}, not {assignment.robots}")
    return out


def classify(diagnostics: list[Diagnostic]) -> str:
    """Why a file did not compile, in the gradebook's words: the one way in refused it (a
    hostile file), a budget refused its size, or it has mistakes (a compile error)."""
    errors = [d for d in diagnostics if d.severity == "error"]
    text = " ".join(d.message + " " + " ".join(d.notes) for d in errors)
    if ("docs/security.md" in text and "--budget" not in text) or "control character" in text:
        return HOSTILE
    if "--budget" in text or "budget" in text:
        return BUDGET
    return COMPILE_ERROR


def _first(diagnostics: list[Diagnostic]) -> str:
    errors = [d for d in diagnostics if d.severity == "error"] or diagnostics
    if not errors:
        return ""
    d = errors[0]
    where = f"{Path(d.path).name}:{d.line}:{d.col}: " if d.line else ""
    more = f" (and {len(errors) - 1} more)" if len(errors) > 1 else ""
    return " ".join(f"{where}{d.message}{more}".split())  # one line: a gradebook cell
