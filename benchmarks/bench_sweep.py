"""Sweep throughput: -j 1 against -j 2, the overhead per run, and a two-worker Dask cluster.

    python benchmarks/bench_sweep.py [--runs 20] [--minutes 25] [--no-dask]

Runs the wall lab ``--runs`` times (seeds 1..N, the full 25 simulated minutes by default)
through ``labsim sweep``'s executors, once each (the machine is shared: quote the load
average with the figures, which this script prints), and reports:

- the elapsed (wall) time with ``-j 1`` and ``-j 2``, and the speed-up (goal: >= 1.9x on 2
  cores); beside each, the CPU time of the sweep and its workers (a local pool's workers are
  this process's children, counted once joined);
- the overhead per run, against the mean run: in the worker (compile, open the world,
  summarise: ``task_time_s - wall_time_s``) and in all (elapsed x processes / runs - mean
  run, which adds starting the workers and the pipes) (goal: < 5% of a 25-minute run); the
  fork server's start, once per sweep, is measured first and separately;
- runs in flight on average (the sum of the runs' times over the elapsed time): how well
  the executor keeps its processes busy, apart from how fast the machine runs each of them;
- runs per second on a ``distributed.LocalCluster`` of two single-threaded worker processes,
  against ``-j 2`` (skipped without the dask extra).
"""
from __future__ import annotations

import argparse
import os
import resource
import statistics
import time
from pathlib import Path

from labsim.runtime.sweep.grid import Row, Task, grid, inspect_files, parse_setting

LAB = str(Path(__file__).resolve().parent.parent / "behaviours" / "wall_follow.yaml")


def tasks(runs: int, minutes: float) -> tuple[list[Task], dict]:
    settings = [parse_setting(f"minutes={minutes:g}")]
    info = inspect_files([LAB], settings)
    return grid([LAB], settings, tuple(range(1, runs + 1)), info), info


def cpu_now() -> float:
    """CPU seconds of this process and of the children it waited for (the local pool's workers,
    joined when it closes; a Dask cluster's processes are not this process's children)."""
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.process_time() + children.ru_utime + children.ru_stime


def timed(executor: object, work: list[Task]) -> tuple[float, list[Row], float]:
    """(wall s, rows, CPU s of this process and its joined children) of the executor's sweep."""
    start, cpu = time.perf_counter(), cpu_now()
    rows = list(executor.results(work))  # type: ignore[attr-defined]
    elapsed = time.perf_counter() - start
    cpu = cpu_now() - cpu
    bad = [r for r in rows if r.failed]
    if bad:
        raise SystemExit(f"{len(bad)} runs failed: {bad[0].status}: {bad[0].message}")
    return elapsed, rows, cpu


def report(name: str, elapsed: float, rows: list[Row], cpu: float, jobs: int) -> float:
    runs = [r.result.wall_time_s for r in rows if r.result]
    mean_run = statistics.fmean(runs)
    in_worker = statistics.fmean(r.task_time_s - r.result.wall_time_s for r in rows if r.result)
    overall = elapsed * jobs / len(rows) - mean_run
    print(f"{name:<22} {elapsed:7.2f} s wall, {cpu:.2f} s CPU for {len(rows)} runs  "
          f"({len(rows) / elapsed:5.2f} runs/s; "
          f"mean run {mean_run:.3f} s; overhead per run {in_worker * 1000:.1f} ms in the worker "
          f"= {100 * in_worker / mean_run:.1f}%, {overall * 1000:.0f} ms in all = {100 * overall / mean_run:.1f}%; "
          f"runs in flight on average {sum(r.task_time_s for r in rows) / elapsed:.2f})")
    return elapsed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=20)
    parser.add_argument("--minutes", type=float, default=25)
    parser.add_argument("--no-dask", action="store_true")
    args = parser.parse_args()
    from labsim.runtime.sweep.pool import LocalPool

    work, info = tasks(args.runs, args.minutes)
    print(f"wall lab, {args.minutes:g} simulated minutes, {args.runs} seeds; "
          f"{os.cpu_count()} cores; load average before: {os.getloadavg()[0]:.2f}")
    start = time.perf_counter()  # once per sweep: the fork server imports labsim; not counted per run
    timed(LocalPool(1), tasks(1, 0.01)[0])
    print(f"{'pool start (once)':<22} {time.perf_counter() - start:7.2f} s wall  (a worker, one tiny run; "
          "the fork server's start where workers come from one)")
    one = report("-j 1", *timed(LocalPool(1), work), 1)
    two = report("-j 2", *timed(LocalPool(2), work), 2)
    print(f"speed-up -j 2 over -j 1: {one / two:.2f}x   (load average now: {os.getloadavg()[0]:.2f})")
    if args.no_dask:
        return
    try:
        from distributed import LocalCluster
    except ImportError:
        print("dask: skipped (pip install 'labsim[dask]')")
        return
    from labsim.runtime.sweep.dask_pool import DaskPool

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                      silence_logs=50) as cluster:
        elapsed, rows, cpu = timed(DaskPool(cluster.scheduler_address, info), work)
        report("dask, 2 workers", elapsed, rows, cpu, 2)  # CPU: this process only (the cluster's are not its children)
    print(f"dask / -j 2 runs per second: {two / elapsed:.2f}   (load average now: {os.getloadavg()[0]:.2f})")


if __name__ == "__main__":
    main()
