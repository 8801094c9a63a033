"""``labsim grade ASSIGNMENT SUBMISSIONS...``: a class graded, from the command line to the files.

The driver of the grader: it reads the assignment (runtime/grade/assignment.py), holds every
submission to its contract (contract.py), runs what passed, each student a job of all its
seeds (runs.py: one compile for them), on the shared batch layer (``labsim.runtime.batch``:
local worker processes, ``-j``, or a Dask cluster), re-using the cache for unchanged
submissions, scores them (score.py) and writes the gradebook (gradebook.py) and the pages
(pages.py). One student's failure is their row, never the batch's. Ctrl-C, SIGTERM and SIGHUP
stop the runs in progress and keep what is done: the students whose runs all finished are
cached and graded, the others are ``interrupted`` rows, and a second grading runs only those.
Exit 0 when every student was graded, 1 when some could not be, 2 for a bad assignment (a
``LabsimError``), 128 + the signal that stopped it (130, 143, 129).
"""
from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import cast
from urllib.parse import urlsplit

from labsim.foundation.diagnostics import Diagnostic, LabsimError
from labsim.foundation.exits import EXIT_FAILED, EXIT_OK
from labsim.foundation.files import read_text
from labsim.foundation.inert import inert
from labsim.foundation.progress import StatusLine, bar
from labsim.runtime.batch import DONE, STOPPED, TIMEOUT, DaskBatch, LocalBatch, Outcome, default_jobs, warm_up
from labsim.runtime.ending import batch_signals, ending, exit_code
from labsim.runtime.grade import runs as seed_runs
from labsim.runtime.grade.assignment import Assignment, read_assignment
from labsim.runtime.grade.contract import (
    CRASH,
    GRADED,
    INTERRUPTED,
    MISMATCH,
    Found,
    Submission,
    check_submission,
    find_submissions,
)
from labsim.runtime.grade.contract import TIMEOUT as TIMEOUT_STATUS
from labsim.runtime.grade.gradebook import cacheable, load_cached, save_cached, write_gradebook
from labsim.runtime.grade.measure import measure_fault_metric
from labsim.runtime.grade.runs import CRASHED, OVER_BUDGET, RAN, TIMED_OUT, Job, Pictures, SeedRun, make_job, run_job
from labsim.runtime.grade.score import Grade, Graded, grade_of, likely_copies

PRELOAD = ("labsim.runtime.grade.runs",)  # what a worker runs, imported once in the fork server


def add_grade_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("assignment", help="the assignment file (docs/grading.md)")
    p.add_argument("submissions", nargs="+",
                   help="behaviour files, folders of them (one student each), or a folder of folders (one per student)")
    p.add_argument("--out", default="grades", metavar="DIR",
                   help="where the gradebook, the pages and the cache go (default: %(default)s)")
    p.add_argument("-j", "--jobs", type=int, default=None, metavar="N",
                   help="worker processes (default: every core)")
    p.add_argument("--executor", choices=("local", "dask"), default="local",
                   help="run on this machine's processes, or on a Dask cluster (--scheduler)")
    p.add_argument("--scheduler", metavar="ADDRESS", help="the Dask scheduler's address, with --executor dask")
    p.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                   help="show a progress bar (default: when stderr is a terminal)")
    p.add_argument("--no-cache", action="store_true", help="run every submission, even those graded before")
    p.add_argument("--feedback-url", default="", metavar="PREFIX",
                   help="where the --out folder will be online (https://.../grades/): the gradebook's and canvas.csv's "
                        "links to the feedback pages become absolute, as an LMS needs them")
    p.add_argument("--no-pages", action="store_true", help="write the gradebook only: no HTML pages, and no pictures "
                                                           "of seed 1's run")


@dataclass(frozen=True)
class Options:
    assignment: str
    submissions: list[str]
    out: Path = Path("grades")
    jobs: int = 0  # 0: every core
    scheduler: object = None  # a Dask scheduler's address (or client): run there
    cache: bool = True
    progress: bool = False
    pages: bool = True  # the pages need seed 1's pictures; the gradebook alone does not
    # a run and its world to a map and an animation: the pictures' renderer, handed over by the
    # command line (applications do not import each other); None: pages without pictures
    pictures: Pictures | None = None
    feedback_url: str = ""  # the links to the pages lead with it (absolute, for an LMS)


def grade_class(options: Options) -> Graded:
    """Grade every submission; see the module docstring. A bad assignment raises LabsimError."""
    assignment = read_assignment(options.assignment)
    if options.scheduler is None:
        warm_up(PRELOAD)  # the workers' imports overlap the reference's runs and the checks
    reference = _reference(assignment)
    found, collisions, skipped = find_submissions(options.submissions)
    if not found:
        raise LabsimError([Diagnostic(" ".join(options.submissions), "no submissions (behaviour files) here")])
    submissions = _check_all(found, assignment, options.jobs or default_jobs())
    cache = options.out / "cache"
    runs: dict[str, list[SeedRun]] = {}
    jobs: list[Job] = []
    reused = 0
    draw = options.pictures if options.pages else None
    for s in submissions:
        if s.status != GRADED:
            continue
        kept = load_cached(cache, s.key, assignment.seeds) if options.cache else None
        if kept is not None and draw is not None and not kept[0].map_png and kept[0].status in (RAN, OVER_BUDGET):
            kept = None  # graded before with --no-pages: its page needs the pictures of its run
        if kept is not None:
            runs[s.student] = kept
            reused += len(kept)
            continue
        # one job a student: its seeds share one compile (runtime/grade/runs.py)
        jobs.append(make_job(s.student, Path(s.path), s.world_file, assignment.seeds, assignment.params,
                             assignment.budgets, assignment.timeout_s, pictures=draw, measure=assignment.measure,
                             moved=assignment.moves))
    keys = {s.student: s.key for s in submissions}

    def finished(student: str, mine: list[SeedRun]) -> None:  # kept at once: a signal later costs none of it
        if options.cache and cacheable(mine):
            save_cached(cache, keys[student], mine)

    done, ended_by = _run_jobs(jobs, options, assignment.timeout_s, finished)
    for job, mine in zip(jobs, done):
        runs[job.student] = mine
    grades = []
    for s in submissions:
        mine = sorted(runs.get(s.student, []), key=lambda r: assignment.seeds.index(r.seed))
        if s.status == GRADED and len(mine) < len(assignment.seeds):
            grades.append(Grade(s.student, s.path, INTERRUPTED, "the grading was stopped before its runs were done; "
                                                                "grade again to finish it",
                                diagnostics=s.diagnostics, runs=tuple(mine), source=s.source))
            continue
        grades.append(grade_of(s, mine, assignment))
    pictures = {g.student: (g.runs[0].map_png, g.runs[0].animation_gif) for g in grades
                if g.runs and g.runs[0].map_png}
    warnings = assignment_warnings(assignment, reference, grades)
    return Graded(assignment, grades, likely_copies(grades), reference, sum(map(len, done)), reused, ended_by,
                  pictures, collisions, skipped, warnings)


def assignment_warnings(assignment: Assignment, reference: Grade | None, grades: list[Grade]) -> list[str]:
    """The assignment's own problems the grading met, for the teacher: its reference does not
    pass it (a criterion it fails is one no honest student passes either), or a measured metric
    faulted on a student's run (the formula's fault, which no student is charged with)."""
    out = []
    if reference is not None:
        failed = [r.name for r in reference.criteria if not r.passed]
        if not reference.scored or failed:
            why = (f"it fails {', '.join(failed)}" if failed else reference.reason) + \
                  (f" ({reference.reason})" if failed and reference.gate else "")
            out.append(f"the reference behaviour {reference.path} does not pass the assignment: "
                       f"{reference.status}, {inert(why)}; check the assignment's criteria before sending grades")
    faults: dict[str, tuple[int, str]] = {}
    for g in grades:
        seen = set()
        for f in (f for r in g.runs for f in r.measure_faults):
            name = measure_fault_metric(f)
            if name not in seen:
                seen.add(name)
                count, first = faults.get(name, (0, f"{g.student}: {f}"))
                faults[name] = (count + 1, first)
    for name, (count, first) in faults.items():
        out.append(f"{_measure_place(assignment, name)}: the measured metric '{name}' faulted on the runs of "
                   f"{count} student{'s' * (count != 1)} (first {inert(first)}); that is the assignment's formula, "
                   "not a student's fault: no_faults does not count it")
    return out


def _measure_place(assignment: Assignment, name: str) -> str:
    """``assignment.yaml:line:col`` of a measured metric's name."""
    decl = next((m for m in assignment.measure if m.name == name), None)
    mark = getattr(decl.key, "start_mark", None) if decl is not None else None
    return f"{assignment.path}:{mark.line + 1}:{mark.column + 1}" if mark is not None else assignment.path


def _check_all(found: list[Found], assignment: Assignment, jobs: int) -> list[Submission]:
    """Every submission held to the contract, on ``jobs`` worker processes (each compiles one);
    one refused when it was found (a link out, a FIFO, a folder without one behaviour) is its row."""
    items = [(f.student, f.path, assignment) for f in found if f.path is not None and f.status == GRADED]
    checked: dict[str, Submission] = {}
    # a file that takes longer to compile than a run may take (a hostile one of 20,000 rules) is
    # stopped there, as its run would be: one file never stalls the class
    limit = len(assignment.seeds) * assignment.timeout_s + 5.0  # a student's, as for their runs (_run_jobs)
    for o in LocalBatch(jobs, limit, name="labsim-grade-check").outcomes(_check, items):
        student, path, _ = items[o.index]
        checked[student] = (o.value if o.kind == DONE else
                            Submission(student, str(path), "", "", TIMEOUT_STATUS,
                                       f"compiling it took longer than the student's time limit of {limit:g} s "
                                       f"({len(assignment.seeds)} seed{'s' * (len(assignment.seeds) != 1)} of "
                                       f"{assignment.timeout_s:g} s, and 5 s), and it was stopped")
                            if o.kind == TIMEOUT else
                            Submission(student, str(path), "", "", CRASH, f"checking it failed: {o.message}"))
    return [checked[f.student] if f.student in checked else
            Submission(f.student, str(f.path or f.student), "", "", f.status if f.status != GRADED else MISMATCH,
                       f.reason) for f in found]


def _check(item: tuple[str, Path, Assignment]) -> Submission:
    return check_submission(*item)


def _reference(assignment: Assignment) -> Grade | None:
    """The reference behaviour, graded like a student: a bad one is a bad assignment (exit 2)."""
    if assignment.reference is None:
        return None
    submission = check_submission("reference", Path(assignment.reference), assignment)
    if submission.status != GRADED:
        raise LabsimError([Diagnostic(assignment.path, f"the reference behaviour {assignment.reference} does not "
                                                       f"meet the assignment: {submission.reason}")])
    runs = run_job(make_job("reference", Path(submission.path), submission.world_file, assignment.seeds,
                            assignment.params, assignment.budgets, assignment.timeout_s, pictures=None,
                            measure=assignment.measure, moved=assignment.moves))
    if any(r.status == seed_runs.STOPPED for r in runs):  # Ctrl-C (or SIGTERM) before any student ran
        raise KeyboardInterrupt
    faulted = [(r.seed, f) for r in runs for f in r.measure_faults]
    if faulted:  # the formula faults on the teacher's own behaviour: it would on every student's
        seed, fault = faulted[0]
        name = measure_fault_metric(fault)
        decl = next((m for m in assignment.measure if m.name == name), None)
        mark = getattr(decl.key, "start_mark", None) if decl is not None else None
        line = mark.line + 1 if mark else 0
        try:
            shown = read_text(assignment.path, "assignment").splitlines()[line - 1] if line else ""
        except (LabsimError, IndexError):
            shown = ""
        raise LabsimError([Diagnostic(assignment.path, f"the measured metric '{name}' faults on the reference "
                                                       f"behaviour's run (seed {seed}: {fault}); fix its formula "
                                                       "before grading",
                                      line, mark.column + 1 if mark else 0, mark.column + 1 + len(name) if mark else 0,
                                      source_line=shown)])
    return grade_of(submission, list(runs), assignment)


class _Runs:
    """Each student's runs as they come; a student whose runs are all done is handed to
    ``finished`` at once (the cache), so that whatever stops the grading later costs none of it."""

    def __init__(self, jobs: list[Job], timeout_s: float, finished: Callable[[str, list[SeedRun]], None]) -> None:
        self.jobs = jobs
        self.timeout_s = timeout_s
        self.done: list[list[SeedRun]] = [[] for _ in jobs]  # the runs that ended by themselves
        self.finished = finished
        self.count = 0  # runs made
        self.total = sum(len(job.seeds) for job in jobs)

    def take(self, outcome: Outcome) -> None:
        job = self.jobs[outcome.index]
        mine = self.done[outcome.index] = [r for r in self._seed_runs(job, outcome) if r.status != seed_runs.STOPPED]
        self.count += len(mine)
        if len(mine) == len(job.seeds):
            self.finished(job.student, mine)

    def _seed_runs(self, job: Job, outcome: Outcome) -> tuple[SeedRun, ...]:
        """A signal's stop is no result (it runs again next time); a killed or dead worker is
        every seed's row, with why."""
        if outcome.kind == DONE:
            return cast(tuple[SeedRun, ...], outcome.value)
        if outcome.kind == STOPPED:
            return ()
        status, message = CRASHED, outcome.message
        if outcome.kind == TIMEOUT:
            status, message = TIMED_OUT, (f"it did not stop at its time limit of {self.timeout_s:g} s a run, "
                                          "and was killed")
        return tuple(SeedRun(seed, status, message, wall_time_s=outcome.wall_s) for seed in job.seeds)


def _run_jobs(jobs: list[Job], options: Options, timeout_s: float,
              finished: Callable[[str, list[SeedRun]], None]) -> tuple[list[list[SeedRun]], int]:
    """Each job's runs that ended by themselves (fewer than its seeds when a signal stopped it),
    and the signal that stopped the grading (0: none). A signal stops the runs in progress
    (``LocalBatch.interrupt``); a run that finished meanwhile is kept."""
    runs = _Runs(jobs, timeout_s, finished)
    if not jobs:
        return runs.done, 0
    line = StatusLine() if options.progress else None
    # a job is a student's runs; the pool kills it a little after the last one's deadline: each
    # run stops itself first, with its message
    seeds = max(len(job.seeds) for job in jobs)
    batch = DaskBatch(options.scheduler) if options.scheduler is not None else LocalBatch(
        options.jobs or default_jobs(), seeds * timeout_s + 5.0, name="labsim-grade-worker", preload=PRELOAD)
    outcomes = batch.outcomes(run_job, jobs)
    try:
        with batch_signals():
            for outcome in outcomes:
                runs.take(outcome)
                if line is not None and (line.due() or runs.count == runs.total):
                    line.draw(f"grading {bar(runs.count / runs.total)} {runs.count}/{runs.total} runs")
    except KeyboardInterrupt as e:
        signum, why = ending(e)
        for outcome in batch.interrupt(why):
            runs.take(outcome)
        return runs.done, signum
    finally:
        if line is not None:
            line.clear()
        close = getattr(outcomes, "close", None)
        if close is not None:
            close()
    return runs.done, 0


def run_grade(args: argparse.Namespace, pictures: Pictures | None = None) -> int:
    """The command: grade, write, say what was written; its exit code."""
    if args.executor == "dask" and not args.scheduler:
        raise LabsimError([Diagnostic("--executor dask", "give the cluster's address: --scheduler ADDRESS")])
    if args.jobs is not None and args.jobs < 1:
        raise LabsimError([Diagnostic("-j", "give 1 or more worker processes")])
    progress = args.progress if args.progress is not None else sys.stderr.isatty()
    options = Options(args.assignment, args.submissions, Path(args.out), args.jobs or 0,
                      args.scheduler if args.executor == "dask" else None, not args.no_cache, progress,
                      pages=not args.no_pages, pictures=pictures, feedback_url=feedback_prefix(args.feedback_url))
    options.out.mkdir(parents=True, exist_ok=True)
    graded = grade_class(options)
    return write_class(graded, options, pages=not args.no_pages)


def feedback_prefix(url: str) -> str:
    """``--feedback-url``: an http(s) address, ending in '/' so that ``feedback/NAME.html`` follows it."""
    if not url:
        return ""
    parts = urlsplit(url)
    if parts.scheme not in ("http", "https") or not parts.netloc or any(ch in url for ch in "\"<> \t\n\r"):
        raise LabsimError([Diagnostic("--feedback-url", f"give the http(s) address the --out folder will have "
                                                         f"online, e.g. https://example.edu/lab4/grades/, not "
                                                         f"{inert(url[:80])!r}")])
    if "?" in url or "#" in url:  # feedback/NAME.html would land in the query or the fragment
        raise LabsimError([Diagnostic("--feedback-url", f"give the folder's address without a query or a fragment "
                                                         f"('?' or '#'): each page's link is the address followed by "
                                                         f"feedback/NAME.html, not {inert(url[:80])!r}")])
    return url if url.endswith("/") else url + "/"


def write_class(graded: Graded, options: Options, pages: bool = True) -> int:
    """Write the gradebook and the pages of a graded class; print the counts; the exit code."""
    inputs = [graded.assignment.path, *(g.path for g in graded.grades)]
    written = write_gradebook(options.out, graded.grades, graded.assignment, graded.copies, graded.reference, inputs,
                              options.feedback_url, graded.collisions, graded.skipped, graded.warnings, pages)
    from labsim.runtime.grade.pages import remove_stale_pages, write_pages

    if pages:
        written += write_pages(options.out, graded, inputs)
    else:  # no page of a last grading stays up beside this gradebook, which links none
        remove_stale_pages(options.out, set(), overview=False)
    counts: dict[str, int] = {}
    for g in graded.grades:
        counts[g.status] = counts.get(g.status, 0) + 1
    print(f"{len(graded.grades)} submissions: " + ", ".join(f"{n} {status}" for status, n in counts.items()))
    print(f"{graded.ran} runs made, {graded.reused} taken from the cache")
    for why, students in graded.copies:
        print(f"likely copies ({why}): {inert(', '.join(students))}")
    for group in graded.collisions:
        print(f"names that collide, each its own row: {inert(', '.join(group))}")
    for passed, why in graded.skipped:
        print(f"passed over: {inert(passed)}: {why}")
    for warning in graded.warnings:
        print(f"labsim grade: warning: {warning}", file=sys.stderr)
    for path in written[:3]:
        print(f"wrote {path}")
    if pages:
        print(f"wrote {options.out / 'index.html'} and {len(graded.grades)} feedback pages in "
              f"{options.out / 'feedback'}")
    if graded.ended_by:
        print(f"interrupted: {sum(g.status == INTERRUPTED for g in graded.grades)} submissions left to grade; "
              "grading again runs only those")
        return exit_code(graded.ended_by)
    return EXIT_OK if all(g.scored for g in graded.grades) else EXIT_FAILED

