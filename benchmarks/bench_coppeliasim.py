"""Round trips per tick and real-time factor of the three labs on the coppeliasim backend.

    python benchmarks/bench_coppeliasim.py [--repeat 3] [--minutes 1]

Each lab runs through ``labsim serve`` on this machine, two ways:

* *per object*: ``labsim serve --for LAB`` (a scene without the fleet script): one request
  per sonar, pose, wheel change and collision check, two for the step;
* *fleet script*: ``labsim serve --empty`` + ``labsim scene LAB``, which adds the fleet
  script: the whole fleet's readings in one call, its wheel changes in one, two for the step.

It prints, per lab and way, the round trips per tick (requests during the run / ticks) and the
median real-time factor (simulated seconds / wall seconds, the run phase only), with the
machine's load average. A real CoppeliaSim adds its own physics and rendering time per step;
the round trips per tick are the same there.
"""
from __future__ import annotations

import argparse
import contextlib
import io
import os
import select
import statistics
import subprocess
import sys
import time
from pathlib import Path

from labsim.backends import load_backend
from labsim.runtime.cli.main import main as cli
from labsim.runtime.run import compile_behaviour

LABS = Path(__file__).resolve().parent.parent / "behaviours"


def serve(*args: str) -> tuple[subprocess.Popen[str], int]:
    """A ``labsim serve`` process on a free port, and the port."""
    proc = subprocess.Popen([sys.executable, "-m", "labsim", "serve", "--port", "0", *args],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    ready, _, _ = select.select([proc.stdout], [], [], 60)
    if not ready:
        proc.kill()
        raise SystemExit("labsim serve did not start within 60 s")
    line = proc.stdout.readline()  # type: ignore[union-attr]
    return proc, int(line.split("127.0.0.1:")[1].split(";")[0])


def once(lab: Path, port: int, ticks: int) -> tuple[float, float, float]:
    """One run: (round trips per tick, simulated s, wall s of the run phase)."""
    backend = load_backend("coppeliasim", port=port)
    run = compile_behaviour(lab).bind(backend, warn=lambda m: None)
    summary = run.run(max_ticks=ticks)
    run.close()
    during = backend.round_trips - backend.round_trips_open  # type: ignore[attr-defined]
    return during / summary.ticks, summary.sim_time_s, summary.wall_time_s


def measure(lab: Path, way: str, repeat: int, ticks: int) -> tuple[float, float] | None:
    """(round trips per tick, median real-time factor) of ``lab`` run ``way``, None if it cannot be built."""
    if way == "per object":
        proc, port = serve("-q", "--for", str(lab))
    else:
        proc, port = serve("-q", "--empty")
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()) as err:
            built = cli(["scene", str(lab), "--port", str(port)]) == 0
        if not built:
            proc.terminate()
            proc.wait()
            print(f"  {lab.stem:12} {way:13} not built: {err.getvalue().strip()}")
            return None
    try:
        runs = [once(lab, port, ticks) for _ in range(repeat)]
    finally:
        proc.terminate()
        proc.wait()
    trips = runs[0][0]
    factor = statistics.median(sim / wall for _, sim, wall in runs)
    return trips, factor


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--minutes", type=float, default=1.0, help="simulated minutes at most per run")
    args = parser.parse_args()
    print(f"coppeliasim backend through labsim serve; load average {os.getloadavg()[0]:.2f}, "
          f"{os.cpu_count()} cores; median of {args.repeat}")
    print(f"  {'lab':12} {'way':13} {'round trips/tick':>17} {'x real time':>12}")
    for name in ("wall_follow", "road_follow", "crane"):
        lab = LABS / f"{name}.yaml"
        ticks = int(args.minutes * 60 / compile_behaviour(lab).program.dt_s)
        for way in ("per object", "fleet script"):
            start = time.perf_counter()
            got = measure(lab, way, args.repeat, ticks)
            if got is not None:
                print(f"  {name:12} {way:13} {got[0]:17.2f} {got[1]:11.1f}x   ({time.perf_counter() - start:.0f} s)")


if __name__ == "__main__":
    main()
