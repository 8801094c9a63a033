"""A submission against the assignment's contract, before anything of it runs.

The second stage of ``labsim grade``: ``find_submissions`` gives each student one id (their
path relative to the submissions folder where stems collide) and refuses, unread, a link out of
the submissions folder, a FIFO or a device. Each submission (a behaviour file, or a folder
holding one) is then compiled as the student wrote it, with the assignment's measured metrics
added (runtime/grade/measure.py) and every diagnostic kept, its structure fingerprinted for
likely copies (runtime/grade/copies.py), and held to the assignment: its world, its number of
robots, the params the grader sets (each must be declared, take the grader's value, and not be
set again by a robot) and the metrics the criteria read. What fails here is
that student's row with its reason — ``hostile file`` (the one way in refused it), ``budget
stop`` (too many robots, camera pixels, ...), ``compile error`` (all its diagnostics) or
``contract mismatch`` (what is missing, with the closest name the file has) — and never stops
the batch. A submission that passes becomes a ``Submission`` the driver makes jobs of.
"""
from __future__ import annotations

import hashlib
import os
import re
import stat
from collections.abc import Iterable
from dataclasses import dataclass, replace
from pathlib import Path

from labsim.backends.scene.world_names import builtin_name
from labsim.dsl.emit.program import Program
from labsim.foundation.diagnostics import Diagnostic, LabsimError, Report, did_you_mean
from labsim.foundation.files import os_words, policy_problem, read_head, read_input
from labsim.foundation.kinds import BEHAVIOUR_ONLY_KEYS, HEAD_BYTES, YAML_SUFFIXES, file_kind, top_level_keys
from labsim.foundation.version import version
from labsim.runtime.grade.assignment import Assignment, budget_words
from labsim.runtime.grade.copies import structures
from labsim.runtime.grade.measure import graded_file, graders, prepare_read, the_assignments, unmeasurable

# a student's status: graded, or why not
GRADED, MISMATCH, COMPILE_ERROR, HOSTILE = "graded", "contract mismatch", "compile error", "hostile file"
# INTERRUPTED: a signal (Ctrl-C, SIGTERM, SIGHUP) stopped the grading before its runs were done
TIMEOUT, BUDGET, CRASH, INTERRUPTED = "timeout", "budget stop", "crash", "interrupted"
# ran, but failed a required criterion: the status names it ("failed gate: no_faults")
FAILED_GATE = "failed gate"
STATUSES = (GRADED, FAILED_GATE, MISMATCH, COMPILE_ERROR, HOSTILE, TIMEOUT, BUDGET, CRASH, INTERRUPTED)


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
    # the file's structure with its names, comments, order (and, second, its numbers) set aside:
    # likely copies share it (runtime/grade/copies.py); empty when it does not read
    structure: tuple[str, str] = ("", "")


@dataclass(frozen=True)
class Found:
    """A submission found on the command line: its student's id, its behaviour file (None when
    there is none; the refused file itself for a hostile one, never read), and the status and
    reason of one refused before a byte of it is read."""

    student: str
    path: Path | None
    status: str = GRADED
    reason: str = ""


def find_submissions(paths: list[str]) -> tuple[list[Found], list[tuple[str, ...]], list[tuple[str, str]]]:
    """Every submission the arguments hold, the groups of students whose names collided, and
    every file or folder passed over, with why (a world file, an assignment file, not YAML, the
    same file given twice): nothing is dropped without a word.

    An argument is a behaviour file, or a folder: each behaviour file in it is a student, and
    each folder in it is a student's folder holding one behaviour file (and any world file it
    reads); a folder may hold both. A student's id is their file's stem (their folder's name),
    or where two of those would be one name (``alice.yaml`` and ``alice.yml``, ``Bob`` and
    ``bob``, the same name in two folders) their path relative to the submissions folder, suffix
    and all, led by the folder's name when that is still not enough. A file found in a folder is
    that folder's, and a file named on the command line is the folder's it lies in: a link out
    of it, and anything but a regular file (a FIFO, a device), is a ``hostile file`` row and
    nothing is read through it (docs/security.md). The same file reached twice is one student."""
    missing = [Diagnostic(str(arg), "no such file or folder") for arg in map(Path, paths) if not os.path.lexists(arg)]
    if missing:  # a mistake on the command line, not a student's
        raise LabsimError(missing)
    entries: list[tuple[Path, str, Found]] = []  # (submissions folder, path relative to it, what was found)
    skipped: list[tuple[str, str]] = []
    for arg in map(Path, paths):
        if not arg.is_dir():  # a file named one by one: the folder it lies in is its folder
            refused = _not_readable(arg, arg.parent)
            entries.append((arg.parent, arg.name, Found(_stem(arg), arg, HOSTILE if refused else GRADED, refused)))
            continue
        # a folder named by the teacher is theirs, even through a link (submissions -> /mnt/lms/...)
        for p in sorted(arg.iterdir()):
            refused = _not_readable(p, arg)
            if p.name.startswith(".") or p.name == "__MACOSX":  # a system's, not a student's (a zip from macOS)
                skipped.append((str(p), "a hidden file or folder" if p.name.startswith(".") else
                                "macOS archive metadata"))
            elif refused:
                entries.append((arg, p.name, Found(_stem(p), p, HOSTILE, refused)))
            elif p.is_dir():
                entries.append((arg, p.name, _one_folder(p, arg)))
            elif not _yaml(p):
                skipped.append((str(p), "not a .yaml or .yml file"))
            else:
                kind = _kind(p)
                if kind == "behaviour":
                    entries.append((arg, p.name, Found(_stem(p), p)))
                else:
                    skipped.append((str(p), f"{'an' if kind[0] in 'aeiou' else 'a'} {kind} file"))
    found, collisions = _named(_unique(entries, skipped))
    return found, collisions, sorted(set(skipped))


def _stem(p: Path) -> str:
    return p.name[:-len(p.suffix)] if _yaml(p) else p.name


def _yaml(p: Path) -> bool:
    """Whether a name is a YAML file's, whatever the case of its suffix (``alice.YAML``)."""
    return p.suffix.lower() in YAML_SUFFIXES


def _kind(p: Path) -> str:
    """What a YAML file in a submissions folder is: a world or an assignment file only when it
    has none of a behaviour's keys (a behaviour with a stray ``labsim-world: 1`` is a student's,
    whose compile error says so), 'behaviour' for every other file, even one that is no labsim
    file at all (its row says why)."""
    kind = file_kind(p)
    if kind in ("world", "assignment"):
        try:
            keys = top_level_keys(read_head(p, HEAD_BYTES).decode("utf-8", "replace"))
        except LabsimError:
            return "behaviour"
        if not keys & (BEHAVIOUR_ONLY_KEYS | {"states", "robots", "let", "metrics", "params"}):
            return kind
    return "behaviour"


def _unique(entries: list[tuple[Path, str, Found]], skipped: list[tuple[str, str]]) -> list[tuple[Path, str, Found]]:
    """The entries with each file (each student's folder) once, by its folder's path with links
    followed and its name: a folder or a file given twice is one student, and the second is
    listed as passed over. A link inside a folder to another file of it is a name of its own
    (a row of its own, and a likely copy)."""
    seen: dict[str, Path] = {}
    out = []
    for entry in entries:
        where = entry[0] / entry[1]
        real = os.path.join(os.path.realpath(entry[0]), entry[1])
        if real in seen:
            skipped.append((str(where), f"the same file as {seen[real]}: one row"))
            continue
        seen[real] = where
        out.append(entry)
    return out


def _not_readable(p: Path, root: Path) -> str:
    """Why a file or folder found in the submissions folder ``root`` is not read: a link out of
    it (``policy_problem``, with no ``--allow-path`` folder: a class reads nothing of the
    teacher's), or no regular file nor folder; '' when it may be read."""
    rel = str(p.relative_to(root))
    why = policy_problem(rel, root, allowed=[])
    if why:
        return f"{p}: {why}; a submission is read only inside its submissions folder"
    try:
        mode = os.stat(p).st_mode
    except OSError as e:
        return f"{p}: cannot read it: {os_words(e)}"
    if not (stat.S_ISREG(mode) or stat.S_ISDIR(mode)):
        kind = ("a FIFO (named pipe)" if stat.S_ISFIFO(mode) else "a socket" if stat.S_ISSOCK(mode)
                else "a device" if stat.S_ISCHR(mode) or stat.S_ISBLK(mode) else "not a regular file")
        return f"{p}: is {kind}, not a regular file"
    return ""


def _one_folder(folder: Path, root: Path) -> Found:
    """A student's folder: its one behaviour file, or why not (a folder of world files only is
    a student who sent no behaviour: a row, never passed over)."""
    listed = sorted(p for p in folder.iterdir() if _yaml(p) and not p.name.startswith("."))
    for p in listed:
        refused = _not_readable(p, root)
        if refused:
            return Found(folder.name, p, HOSTILE, refused)
    found = [p for p in listed if p.is_file() and _kind(p) == "behaviour"]
    if len(found) != 1:
        return Found(folder.name, None, MISMATCH, f"the folder {folder} holds {len(found)} behaviour files; a "
                                                  "student's folder holds one")
    return Found(folder.name, found[0])


def _named(entries: list[tuple[Path, str, Found]]) -> tuple[list[Found], list[tuple[str, ...]]]:
    """Each submission's id, unique and a real path (see ``find_submissions``): ids that differ
    only in case are two ids (their pages' names differ by a hash: gradebook.page_names)."""
    def groups(names: list[str], fold: bool) -> dict[str, list[int]]:
        out: dict[str, list[int]] = {}
        for i, name in enumerate(names):
            out.setdefault(name.casefold() if fold else name, []).append(i)
        return out

    names = [f.student for _, _, f in entries]
    collided = [g for g in groups(names, True).values() if len(g) > 1]
    for group in collided:
        for i in group:
            names[i] = entries[i][1]  # the path relative to its submissions folder, suffix and all
    for group in groups(names, False).values():
        if len(group) > 1:
            for i in group:
                names[i] = f"{entries[i][0].name or entries[i][0]}/{entries[i][1]}"
    for group in groups(names, False).values():
        if len(group) > 1:  # two folders of one name (x/g1, y/g1): the paths as given
            for i in group:
                names[i] = str(entries[i][0] / entries[i][1])
    found = [replace(f, student=name) for (_, _, f), name in zip(entries, names)]
    return found, [tuple(names[i] for i in g) for g in collided]


def _text(data: bytes) -> str | None:
    """The file's text as the compiler reads it, or None to let the compiler say why it is not text."""
    try:
        return data.decode("utf-8").lstrip("\ufeff")
    except UnicodeDecodeError:
        return None


def key_of(data: bytes, assignment: Assignment) -> str:
    digest = hashlib.sha256(data + b"\0" + version().encode() + b"\0" + assignment.sha256.encode())
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
    report = Report()
    try:
        bf = graded_file(path, report, assignment.measure, assignment.moves, text=_text(data))
        base = replace(base, structure=structures(bf))
        program = prepare_read(bf, report, budgets=assignment.budgets).program(None)
    except LabsimError as e:
        if the_assignments(e.diagnostics, assignment.path):
            return _refused(base, MISMATCH, unmeasurable(e, assignment.path),
                            [d for d in e.diagnostics if not graders(d, assignment.path)])
        own = [d for d in e.diagnostics if not graders(d, assignment.path)]  # the file's, not the grader's
        status = classify(own)
        return _refused(base, status, _first(own), own)
    warnings = tuple(w for w in program.warnings if w.path == program.path)  # not the grader's metrics'
    program = replace(program, warnings=warnings)
    world_file = None if builtin_name(program.world.source) else program.world.source
    if world_file is not None and not _inside(Path(world_file), path.parent):
        return _refused(base, HOSTILE, f"its world file {world_file} resolves outside the student's folder; "
                                       "nothing outside it is read", program.warnings)
    problems = contract_problems(program, assignment)
    if problems:
        return _refused(base, MISMATCH, "; ".join(problems), program.warnings)
    if world_file is not None:  # a changed world file is a changed submission: it is graded anew
        try:
            key = key_of(data + b"\0" + read_input(world_file, "world"), assignment)
        except LabsimError as e:
            return _refused(base, HOSTILE, _first(e.diagnostics), e.diagnostics)
    return replace(base, key=key, diagnostics=tuple(program.warnings), world_file=world_file)


def _refused(base: Submission, status: str, reason: str, diagnostics: Iterable[Diagnostic]) -> Submission:
    # a budget's hint names the assignment's budgets: labsim grade has no --budget
    shown = tuple(replace(d, message=budget_words(d.message), notes=tuple(map(budget_words, d.notes)))
                  for d in diagnostics)
    return replace(base, status=status, reason=reason, diagnostics=shown)


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
    for group in program.robots:  # a robot's own value would stand in for the grader's
        for name, _ in group.params:
            if name in assignment.params:
                out.append(f"robot '{group.name}' sets its own value of the grader's param '{name}'")
    for group in program.robots:  # noise on the readings would change what the grader measures
        if group.noise is not None or any(n is not None for n in group.member_noise):
            out.append(f"robot '{group.name}' sets its own noise: the grader measures every run without noise "
                       "(remove noise: to be graded)")
    for name in assignment.metrics:
        if name not in metrics:
            out.append(f"missing metric '{name}'{did_you_mean(name, metrics)}")
    if assignment.world is not None and assignment.world_sha256:
        # the world's content, not its name: a world file of its own named as the assignment's
        # world is another world
        try:
            theirs = hashlib.sha256(read_input(world.source, "world")).hexdigest()
        except LabsimError:
            theirs = ""
        if theirs != assignment.world_sha256:
            shown = builtin_name(world.source) or Path(world.source).name
            named = f" (named '{world.name}')" if world.name != shown else ""
            out.append(f"another world: it uses '{shown}'{named}, not the assignment's world '{assignment.world}'")
    elif assignment.world is not None and assignment.world not in (world.name, Path(world.source).stem):
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
    return budget_words(" ".join(f"{where}{d.message}{more}".split()))  # one line: a gradebook cell
