"""Grading throughput: a class of wall-following submissions through ``labsim grade``.

    python benchmarks/bench_grade.py [--students 200] [--seeds 3] [--minutes 5] [--rounds 2]
                                     [--no-pages] [--split] [--speed-up]

Writes ``--students`` copies of the wall lab with different gains into a scratch folder, and an
assignment that runs each for ``--minutes`` simulated minutes on ``--seeds`` seeds, then
measures, each side a process of its own (``--phase``), alternated round by round in a random
order (benchmarks/compare.py ``alternate``):

- ``bare``: the same runs (compile and run, nothing else) on the same pool with ``-j 2``;
- ``grade``: ``labsim grade -j 2`` (contract check, runs with seed 1 traced, cache, gradebook,
  and the pages with a map and a GIF per student, unless ``--no-pages``);
- with ``--split``, also ``grade-nopages`` (``--no-pages``: the gradebook only, seed 1 untraced),
  to tell the pages' share (the trace they draw from, the maps, the GIFs, the charts) from the rest.

The overhead of grading over the bare runs (goal: <= 10%) is read from **CPU time**: the side's
process and every process under it (its fork server and workers, which this process adopts as
their subreaper so that their time is counted when they end): another user's load slows that far
less than wall time. Each side also says its parent process's own CPU (the rest is its workers'),
and for a grading the parent's CPU in ``grade_class`` and in ``write_class`` (serial, after the
runs); wall times are printed with the 1-minute load average before and after each side.
``--speed-up`` also runs the bare runs and the grading once each with ``-j 1`` and prints both
wall-time speed-ups of ``-j 2`` (goal for grading: >= 1.8x): the bare runs' is the machine's
ceiling (two workers against one on these cores under this load, no grading at all), so grading's
over the bare runs' says what grading itself costs of the speed-up, even on a busy machine.
"""
from __future__ import annotations

import argparse
import contextlib
import ctypes
import io
import json
import os
import random
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from compare import alternate, machine, pair_ratios

from labsim.backends import DEFAULT, load_backend
from labsim.runtime.batch import LocalBatch
from labsim.runtime.grade.driver import Options, grade_class, write_class
from labsim.runtime.pictures.feedback import feedback_pictures
from labsim.runtime.run import compile_behaviour

LAB = Path(__file__).resolve().parent.parent / "behaviours" / "wall_follow.yaml"


def make_class(folder: Path, students: int, seeds: int, minutes: float) -> None:
    text = LAB.read_text().split("\n", 1)[1]  # less the schema modeline
    rng = random.Random(1)
    (folder / "class").mkdir()
    for i in range(students):
        gains = text.replace("front: 0.5 ", f"front: {rng.uniform(0.35, 0.8):.3f} ")
        gains = gains.replace("side: 0.3 ", f"side: {rng.uniform(0.25, 0.35):.3f} ")
        gains = gains.replace("cruise: 2 ", f"cruise: {rng.uniform(1.5, 2):.2f} ")
        (folder / "class" / f"student_{i:03d}.yaml").write_text(gains)
    (folder / "assignment.yaml").write_text(
        f"labsim-assignment: 1\ntitle: bench\nworld: walls_lab4\nrobots: 1\nparams: {{minutes: {minutes:g}}}\n"
        f"seeds: [{', '.join(str(s) for s in range(1, seeds + 1))}]\ntimeout_s: 600\n"
        "criteria:\n  following: {score: [0, 100]}\n  no_faults: {}\n")
    (folder / "minutes").write_text(f"{minutes:g}")
    (folder / "seeds").write_text(str(seeds))


def bare_run(job: tuple[str, int, float]) -> float:
    """One run, nothing else: compile with the seed and the grader's minutes, run, close."""
    path, seed, minutes = job
    run = compile_behaviour(path, {"minutes": f"{minutes:g}"}, seed=seed).bind(load_backend(DEFAULT))
    try:
        return run.run().wall_time_s
    finally:
        run.close()


def grade(folder: Path, jobs: int, pages: bool, out: Path) -> dict[str, float]:
    """Grade the class; the parent process's own CPU seconds in each part (the workers' are not in
    them): ``grade_class`` (the checks, the runs' hand-out and collection) and ``write_class``."""
    out.mkdir()
    options = Options(str(folder / "assignment.yaml"), [str(folder / "class")], out, jobs=jobs, cache=False,
                      pages=pages, pictures=feedback_pictures if pages else None)
    start = time.process_time()
    graded = grade_class(options)
    ran = time.process_time()
    with contextlib.redirect_stdout(io.StringIO()):
        write_class(graded, options, pages=pages)
    bad = [g for g in graded.grades if not g.graded]
    if bad:
        raise SystemExit(f"{len(bad)} students not graded: {bad[0].status}: {bad[0].reason}")
    return {"grade_class": ran - start, "write_class": time.process_time() - ran}


PR_SET_CHILD_SUBREAPER = 36  # linux/prctl.h: orphaned descendants become this process's children


def tree_cpu() -> float:
    """CPU seconds (user + system) of every finished process under this one, once each is reaped."""
    while True:  # reap the adopted orphans (a side's fork server, which reaped its workers)
        try:
            pid, _ = os.waitpid(-1, 0)
        except ChildProcessError:
            break
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


@dataclass(frozen=True)
class Measured:
    """One side's run: CPU of its whole process tree and of its parent process alone (the rest is
    its workers' and fork server's), its wall time, and the 1-minute load average around it."""

    cpu_s: float
    parent_cpu_s: float
    wall_s: float
    load: tuple[float, float]  # before, after
    parts: dict[str, float]  # the parent's CPU by part (grading sides)


def side(folder: Path, phase: str, jobs: int, measured: dict[str, list[Measured]], name: str) -> float:
    """One side, as a process of its own: its CPU seconds (the whole tree); all it measured into ``measured``."""
    before, load = tree_cpu(), os.getloadavg()[0]
    start = time.perf_counter()
    done = subprocess.run([sys.executable, __file__, "--phase", phase, "--folder", str(folder), "--jobs", str(jobs)],
                          check=True, stdout=subprocess.PIPE, text=True)
    wall = time.perf_counter() - start
    cpu = tree_cpu() - before
    told = json.loads(done.stdout.strip().splitlines()[-1])  # the phase's last line: its own CPU
    measured.setdefault(name, []).append(
        Measured(cpu, told["parent_cpu_s"], wall, (load, os.getloadavg()[0]), told.get("parts", {})))
    return cpu


def phase(args: argparse.Namespace) -> None:
    """One side, in this process: ``bare`` runs, or ``grade`` / ``grade-nopages``; its last line of
    output is its own CPU (this process alone), as JSON."""
    folder = Path(args.folder)
    parts: dict[str, float] = {}
    if args.phase == "bare":
        minutes = float((folder / "minutes").read_text())
        items = [(str(f), s, minutes) for f in sorted((folder / "class").iterdir())
                 for s in range(1, int((folder / "seeds").read_text()) + 1)]
        for _ in LocalBatch(args.jobs).outcomes(bare_run, items):
            pass
    else:
        parts = grade(folder, args.jobs, args.phase == "grade", folder / f"out-{args.phase}-{os.getpid()}")
    usage = resource.getrusage(resource.RUSAGE_SELF)
    print(json.dumps({"parent_cpu_s": usage.ru_utime + usage.ru_stime, "parts": parts}))


def _line(name: str, values: list[Measured], runs: int) -> str:
    cpu, wall = [m.cpu_s for m in values], [m.wall_s for m in values]
    parent = statistics.median(m.parent_cpu_s for m in values)
    loads = f"{min(m.load[0] for m in values):.1f}-{max(max(m.load) for m in values):.1f}"
    return (f"  {name:<20} CPU {statistics.median(cpu):7.1f} s ({', '.join(f'{v:.1f}' for v in cpu)}): "
            f"parent {parent:.1f} s, workers {statistics.median(cpu) - parent:.1f} s; wall "
            f"{statistics.median(wall):7.1f} s ({', '.join(f'{v:.1f}' for v in wall)}), "
            f"{runs / statistics.median(wall):.2f} runs/s; load {loads}")


def speed_up(folder: Path, graded: str, measured: dict[str, list[Measured]], runs: int) -> None:
    """The bare runs and the grading once each with -j 1, in a random order: each one's -j 2 over
    -j 1 (wall). The bare runs' ratio is the machine's ceiling: what two worker processes give
    over one on these cores under this load, with no grading at all."""
    sides = {"bare -j 1": lambda: side(folder, "bare", 1, measured, "bare -j 1"),
             f"{graded} -j 1": lambda: side(folder, graded, 1, measured, f"{graded} -j 1")}
    alternate(sides, 1, seed=2)
    for name in sides:
        print(_line(name, measured[name], runs))
    ratios = {}
    for base in ("bare", graded):
        one = measured[f"{base} -j 1"][0].wall_s
        ratios[base] = one / statistics.median(m.wall_s for m in measured[f"{base} -j 2"])
        print(f"speed-up -j 2 over -j 1 (wall), {base}: {ratios[base]:.2f}x"
              + (" (goal >= 1.8x)" if base == graded else " (the machine's ceiling)"))
    print(f"grading's speed-up over the bare runs' (1.00: grading scales as the bare runs do): "
          f"{ratios[graded] / ratios['bare']:.2f}")
    for name in (f"{graded} -j 2", f"{graded} -j 1"):
        parts = measured[name][-1].parts
        print(f"  {name}: the parent's CPU in grade_class {parts.get('grade_class', 0):.2f} s, "
              f"in write_class {parts.get('write_class', 0):.2f} s (serial, after the runs)")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--students", type=int, default=200)
    p.add_argument("--seeds", type=int, default=3)
    p.add_argument("--minutes", type=float, default=5.0)
    p.add_argument("--rounds", type=int, default=2, help="rounds of the alternated sides (default: 2)")
    p.add_argument("--no-pages", action="store_true", help="grade without the pages")
    p.add_argument("--split", action="store_true", help="also grade without the pages, to tell their share")
    p.add_argument("--speed-up", action="store_true",
                   help="also run the bare runs and the grading with -j 1 once each (wall time)")
    p.add_argument("--phase", choices=("bare", "grade", "grade-nopages"), help=argparse.SUPPRESS)
    p.add_argument("--folder", help=argparse.SUPPRESS)
    p.add_argument("--jobs", type=int, default=2, help=argparse.SUPPRESS)
    args = p.parse_args()
    if args.phase:
        phase(args)
        return
    ctypes.CDLL(None).prctl(PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0)
    runs = args.students * args.seeds
    print(machine())
    print(f"{args.students} submissions x {args.seeds} seeds = {runs} runs of {args.minutes:g} simulated minutes")
    with tempfile.TemporaryDirectory(prefix="bench-grade-") as d:
        folder = Path(d)
        make_class(folder, args.students, args.seeds, args.minutes)
        measured: dict[str, list[Measured]] = {}
        graded = "grade-nopages" if args.no_pages else "grade"
        names = ["bare -j 2", f"{graded} -j 2"] + (["grade-nopages -j 2"] if args.split and not args.no_pages else [])
        sides = {name: (lambda name=name: side(folder, name.split()[0], 2, measured, name)) for name in names}
        cpu = alternate(sides, args.rounds, seed=1)
        print(f"each side's process tree (parent and workers), medians of {args.rounds} rounds in random order:")
        for name in cpu:
            print(_line(name, measured[name], runs))
        for name in cpu:
            if name != "bare -j 2":
                over = statistics.median(pair_ratios(cpu[name], cpu["bare -j 2"]))
                print(f"overhead of grading ({name}) over the bare runs, CPU: {100 * (over - 1):+.1f}% "
                      f"(median of per-round ratios; goal <= 10%)")
        if args.speed_up:
            speed_up(folder, graded, measured, runs)
    print(machine())


if __name__ == "__main__":
    main()
