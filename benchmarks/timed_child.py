"""One command timed as a user meets it: a new process, its wall time, its CPU time with its
children's (ffmpeg for an MP4), and its peak memory.

``timed`` starts the command, waits for it with ``os.wait4`` (whose resource usage counts the
process and the children it waited for), and returns the three figures; ``rounds`` runs several
commands in a fresh random order each round, so that a busy moment of a shared machine does not
always fall on the same one (the pictures' and the plot's benchmarks use it).
"""
from __future__ import annotations

import os
import random
import statistics
import subprocess
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass

MIB = 1024 * 1024


@dataclass(frozen=True)
class Timing:
    wall_s: float
    cpu_s: float  # user + system, the process and its children
    peak_mib: float  # the largest resident set of the process or one of its children


def timed(argv: Sequence[str], env: dict[str, str] | None = None) -> Timing:
    """Run argv to its end (its output thrown away); a failure is an error, not a time."""
    start = time.perf_counter()
    proc = subprocess.Popen(list(argv), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=env)
    assert proc.stderr is not None
    err = proc.stderr.read()
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - start
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(argv)} ended with {proc.returncode}: {err.decode(errors='replace')[-500:]}")
    return Timing(wall, usage.ru_utime + usage.ru_stime, usage.ru_maxrss * 1024 / MIB)


def labsim(*args: str) -> list[str]:
    """The command line of ``labsim ARGS`` with this Python."""
    return [sys.executable, "-m", "labsim", *args]


def rounds(cases: dict[str, list[str]], repeat: int, seed: int | None = None) -> dict[str, list[Timing]]:
    """Each command ``repeat`` times, every round in a fresh random order; the timings by name."""
    rng = random.Random(seed)
    out: dict[str, list[Timing]] = {name: [] for name in cases}
    names = list(cases)
    for _ in range(repeat):
        rng.shuffle(names)
        for name in names:
            out[name].append(timed(cases[name]))
    return out


def load() -> str:
    one, five, fifteen = os.getloadavg()
    return f"load {one:.2f} {five:.2f} {fifteen:.2f}"


def print_medians(times: dict[str, list[Timing]]) -> None:
    """Each case's median wall and CPU time and its peak memory, one line each."""
    for name, runs in times.items():
        wall = statistics.median(t.wall_s for t in runs)
        cpu = statistics.median(t.cpu_s for t in runs)
        print(f"  {name}: {wall:.2f} s wall, {cpu:.2f} s CPU, peak {max(t.peak_mib for t in runs):.0f} MiB")
