"""Memory stays flat with run length: peak RSS of the wall lab at 1 and at 60 simulated minutes.

    python benchmarks/bench_memory.py [--minutes 1 60] [--trace]

Each length runs in a process of its own (``labsim run behaviours/wall_follow.yaml --set
minutes=N``, through labsim's command line, so with everything a user's run does: the
summary, the metrics, the rule counts), which then prints its peak resident set size. A
run keeps no per-tick history unless it writes a trace, and a trace is written as it goes,
so the peak should not grow with the run's length (goal: the same to within a few MB).
With ``--trace`` each run also writes its trace to a temporary file.
"""
from __future__ import annotations

import argparse
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from compare import machine

LAB = Path(__file__).resolve().parent.parent / "behaviours" / "wall_follow.yaml"

# Runs labsim's command line in this process, then reports the process's peak RSS in KiB
# (Linux reports ru_maxrss in KiB, macOS in bytes).
CHILD = """
import contextlib, io, resource, sys
from labsim.runtime.cli.main import main
with contextlib.redirect_stdout(io.StringIO()):
    code = main(sys.argv[1:])
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(code, peak // 1024 if sys.platform == "darwin" else peak)
"""


def peak_kib(minutes: float, trace: Path | None) -> tuple[int, float, float]:
    """The run's peak RSS in KiB, its process's wall and CPU seconds (user + system)."""
    argv = ["run", str(LAB), "--set", f"minutes={minutes:g}"] + (["--trace", str(trace)] if trace else [])
    before, start = resource.getrusage(resource.RUSAGE_CHILDREN), time.perf_counter()
    done = subprocess.run([sys.executable, "-c", CHILD, *argv], capture_output=True, text=True, check=False)
    wall, after = time.perf_counter() - start, resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime
    code, peak = done.stdout.split()[-2:] if done.stdout.strip() else ("?", "0")
    if code != "0":
        raise SystemExit(f"labsim {' '.join(argv)} failed ({code}):\n{done.stderr}")
    return int(peak), wall, cpu


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=float, nargs="+", default=[1, 60])
    parser.add_argument("--trace", action="store_true")
    args = parser.parse_args()
    print(machine())
    peaks = []
    with tempfile.TemporaryDirectory() as d:
        for minutes in args.minutes:
            peak, wall, cpu = peak_kib(minutes, Path(d) / "trace.csv" if args.trace else None)
            peaks.append(peak)
            print(f"wall lab, {minutes:g} simulated minutes ({round(minutes * 60 / 0.05):,} ticks)"
                  f"{', with trace' if args.trace else ''}: peak RSS {peak / 1024:.1f} MiB "
                  f"({wall:.2f} s wall, {cpu:.2f} s CPU, the whole process)")
    print(f"  peak RSS, longest run minus shortest: {(peaks[-1] - peaks[0]) / 1024:+.1f} MiB   (goal: flat)")


if __name__ == "__main__":
    main()
