"""Grading throughput: a class of wall-following submissions through ``labsim grade``.

    python benchmarks/bench_grade.py [--students 200] [--seeds 3] [--minutes 5] [--no-pages]

Writes ``--students`` copies of the wall lab with different gains into a scratch folder, and an
assignment that runs each for ``--minutes`` simulated minutes on ``--seeds`` seeds, then reports
(the machine is shared: quote the load average with the figures, which this script prints):

- runs per second grading with ``-j 1`` and with ``-j 2``, and the speed-up (goal: >= 1.8x on 2 cores);
- the overhead of grading over the bare runs: the same runs (compile and run, nothing else) on
  the same pool with ``-j 2``, against grading with ``-j 2`` (contract check, cache, gradebook,
  pages with a map per student) (goal: <= 10%).
"""
from __future__ import annotations

import argparse
import os
import random
import tempfile
import time
from pathlib import Path

from labsim.backends import DEFAULT, load_backend
from labsim.runtime.batch import LocalBatch
from labsim.runtime.grade.driver import Options, grade_class, write_class
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


def bare_run(job: tuple[str, int, float]) -> float:
    """One run, nothing else: compile with the seed and the grader's minutes, run, close."""
    path, seed, minutes = job
    run = compile_behaviour(path, {"minutes": f"{minutes:g}"}, seed=seed).bind(load_backend(DEFAULT))
    try:
        return run.run().wall_time_s
    finally:
        run.close()


def grade(folder: Path, jobs: int, pages: bool) -> float:
    out = folder / f"out-j{jobs}"
    out.mkdir()
    options = Options(str(folder / "assignment.yaml"), [str(folder / "class")], out, jobs=jobs, cache=False)
    start = time.perf_counter()
    graded = grade_class(options)
    if pages:
        from labsim.runtime.cli.commands import draw_pictures

        write_class(graded, options, draw_pictures)
    else:
        write_class(graded, options, None, pages=False)
    elapsed = time.perf_counter() - start
    bad = [g for g in graded.grades if not g.graded]
    if bad:
        raise SystemExit(f"{len(bad)} students not graded: {bad[0].status}: {bad[0].reason}")
    return elapsed


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--students", type=int, default=200)
    p.add_argument("--seeds", type=int, default=3)
    p.add_argument("--minutes", type=float, default=5.0)
    p.add_argument("--no-pages", action="store_true", help="write the gradebook only")
    args = p.parse_args()
    runs = args.students * args.seeds
    print(f"{args.students} submissions x {args.seeds} seeds = {runs} runs of {args.minutes:g} simulated minutes; "
          f"load average before: {os.getloadavg()[0]:.2f}")
    with tempfile.TemporaryDirectory(prefix="bench-grade-") as d:
        folder = Path(d)
        make_class(folder, args.students, args.seeds, args.minutes)
        items = [(str(f), s, args.minutes) for f in sorted((folder / "class").iterdir())
                 for s in range(1, args.seeds + 1)]
        start = time.perf_counter()
        walls = [o.value for o in LocalBatch(2).outcomes(bare_run, items)]
        bare = time.perf_counter() - start
        print(f"bare runs -j 2: {bare:.1f} s, {runs / bare:.2f} runs/s (mean run {sum(walls) / len(walls):.2f} s)")
        one = grade(folder, 1, not args.no_pages)
        print(f"labsim grade -j 1: {one:.1f} s, {runs / one:.2f} runs/s")
        two = grade(folder, 2, not args.no_pages)
        print(f"labsim grade -j 2: {two:.1f} s, {runs / two:.2f} runs/s")
        print(f"speed-up -j 2 over -j 1: {one / two:.2f}x (goal >= 1.8x)")
        print(f"overhead of grading over the bare runs (-j 2): {100 * (two - bare) / bare:+.1f}% (goal <= 10%)")
    print(f"load average after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
