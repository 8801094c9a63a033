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
less than wall time. Wall times are printed too, with the load average. ``--speed-up`` also
grades once with ``-j 1`` and prints the wall-time speed-up of ``-j 2`` (goal: >= 1.8x), which
means something only on a quiet machine.
"""
from __future__ import annotations

import argparse
import ctypes
import os
import random
import resource
import statistics
import subprocess
import sys
import tempfile
import time
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
        gains = gains.replace("hold: 0.45 ", f"hold: {rng.uniform(0.35, 0.6):.3f} ")
        gains = gains.replace("cruise: 4 ", f"cruise: {rng.uniform(3, 5):.2f} ")
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


def grade(folder: Path, jobs: int, pages: bool, out: Path) -> float:
    out.mkdir()
    options = Options(str(folder / "assignment.yaml"), [str(folder / "class")], out, jobs=jobs, cache=False,
                      pages=pages, pictures=feedback_pictures if pages else None)
    start = time.perf_counter()
    graded = grade_class(options)
    write_class(graded, options, pages=pages)
    elapsed = time.perf_counter() - start
    bad = [g for g in graded.grades if not g.graded]
    if bad:
        raise SystemExit(f"{len(bad)} students not graded: {bad[0].status}: {bad[0].reason}")
    return elapsed


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


def side(folder: Path, phase: str, jobs: int, walls: dict[str, list[float]], name: str) -> float:
    """One side, as a process of its own: its CPU seconds (the whole tree); its wall time into ``walls``."""
    before = tree_cpu()
    start = time.perf_counter()
    subprocess.run([sys.executable, __file__, "--phase", phase, "--folder", str(folder), "--jobs", str(jobs)],
                   check=True, stdout=subprocess.DEVNULL)
    walls.setdefault(name, []).append(time.perf_counter() - start)
    return tree_cpu() - before


def phase(args: argparse.Namespace) -> None:
    """One side, in this process: ``bare`` runs, or ``grade`` / ``grade-nopages``."""
    folder = Path(args.folder)
    if args.phase == "bare":
        minutes = float((folder / "minutes").read_text())
        items = [(str(f), s, minutes) for f in sorted((folder / "class").iterdir())
                 for s in range(1, int((folder / "seeds").read_text()) + 1)]
        for _ in LocalBatch(args.jobs).outcomes(bare_run, items):
            pass
        return
    out = folder / f"out-{args.phase}-{os.getpid()}"
    grade(folder, args.jobs, args.phase == "grade", out)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--students", type=int, default=200)
    p.add_argument("--seeds", type=int, default=3)
    p.add_argument("--minutes", type=float, default=5.0)
    p.add_argument("--rounds", type=int, default=2, help="rounds of the alternated sides (default: 2)")
    p.add_argument("--no-pages", action="store_true", help="grade without the pages")
    p.add_argument("--split", action="store_true", help="also grade without the pages, to tell their share")
    p.add_argument("--speed-up", action="store_true", help="also grade with -j 1 once (wall time)")
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
        walls: dict[str, list[float]] = {}
        graded = "grade-nopages" if args.no_pages else "grade"
        sides = {"bare -j 2": lambda: side(folder, "bare", 2, walls, "bare -j 2"),
                 f"{graded} -j 2": lambda: side(folder, graded, 2, walls, f"{graded} -j 2")}
        if args.split and not args.no_pages:
            sides["grade-nopages -j 2"] = lambda: side(folder, "grade-nopages", 2, walls, "grade-nopages -j 2")
        cpu = alternate(sides, args.rounds, seed=1)
        print(f"CPU seconds of each side's process tree, medians of {args.rounds} rounds in random order:")
        for name, values in cpu.items():
            print(f"  {name:<20} CPU {statistics.median(values):7.1f} s ({', '.join(f'{v:.1f}' for v in values)}); "
                  f"wall {statistics.median(walls[name]):7.1f} s ({', '.join(f'{v:.1f}' for v in walls[name])}), "
                  f"{runs / statistics.median(walls[name]):.2f} runs/s")
        for name in cpu:
            if name != "bare -j 2":
                over = statistics.median(pair_ratios(cpu[name], cpu["bare -j 2"]))
                print(f"overhead of grading ({name}) over the bare runs, CPU: {100 * (over - 1):+.1f}% "
                      f"(median of per-round ratios; goal <= 10%)")
        if args.speed_up:
            one = side(folder, graded, 1, walls, "j1")
            print(f"{graded} -j 1: CPU {one:.1f} s, wall {walls['j1'][0]:.1f} s; speed-up -j 2 over -j 1 (wall): "
                  f"{walls['j1'][0] / statistics.median(walls[f'{graded} -j 2']):.2f}x (goal >= 1.8x)")
    print(machine())


if __name__ == "__main__":
    main()
