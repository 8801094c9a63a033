"""Round trips per tick and real-time factor of the three labs on the coppeliasim backend.

    python benchmarks/bench_coppeliasim.py [--repeat 3] [--minutes 1]

Each lab runs through ``labsim serve`` on this machine, three ways:

* *per object*: ``labsim serve --for LAB --per-object`` (a scene without the fleet script, as
  one built by hand): one request per sonar, pose, wheel change and collision check, two for
  the step;
* *serve --for*: ``labsim serve --for LAB``, the student's path: the served scene carries the
  fleet script, so the whole fleet's readings go in one call, its wheel changes in one, two
  for the step;
* *fleet script*: ``labsim serve --empty`` + ``labsim scene LAB``, which adds the fleet script.

It prints, per lab and way, the round trips per tick (requests during the run / ticks), the
median real-time factor (simulated seconds / wall seconds, the run phase only), and the CPU
seconds of the client's runs and of the ``labsim serve`` child over its whole life (start-up
and scene building included), with the machine's load average. A real CoppeliaSim adds its
own physics and rendering time per step; the round trips per tick are the same there.
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


def stop(proc: subprocess.Popen[str]) -> float:
    """Stop a ``labsim serve`` child; its CPU seconds (user + system) over its life."""
    proc.terminate()
    _, _, usage = os.wait4(proc.pid, 0)
    proc.returncode = 0  # reaped here: Popen must not wait for it again
    return usage.ru_utime + usage.ru_stime


def measure(lab: Path, way: str, repeat: int, ticks: int) -> tuple[float, float, float, float] | None:
    """(round trips per tick, median real-time factor, client CPU s, server CPU s) of ``lab``
    run ``way``, None if it cannot be built."""
    if way == "per object":
        proc, port = serve("-q", "--for", str(lab), "--per-object")
    elif way == "serve --for":
        proc, port = serve("-q", "--for", str(lab))
    else:
        proc, port = serve("-q", "--empty")
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()) as err:
            built = cli(["scene", str(lab), "--port", str(port)]) == 0
        if not built:
            stop(proc)
            print(f"  {lab.stem:12} {way:13} not built: {err.getvalue().strip()}")
            return None
    cpu = time.process_time()
    try:
        runs = [once(lab, port, ticks) for _ in range(repeat)]
    finally:
        server_cpu = stop(proc)
    trips = runs[0][0]
    factor = statistics.median(sim / wall for _, sim, wall in runs)
    return trips, factor, time.process_time() - cpu, server_cpu


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--minutes", type=float, default=1.0, help="simulated minutes at most per run")
    args = parser.parse_args()
    print(f"coppeliasim backend through labsim serve; load average {os.getloadavg()[0]:.2f}, "
          f"{os.cpu_count()} cores; median of {args.repeat}")
    print(f"  {'lab':12} {'way':13} {'round trips/tick':>17} {'x real time':>12} {'wall s':>7} "
          f"{'client CPU s':>13} {'server CPU s':>13}")
    for name in ("wall_follow", "road_follow", "crane"):
        lab = LABS / f"{name}.yaml"
        ticks = int(args.minutes * 60 / compile_behaviour(lab).program.dt_s)
        for way in ("per object", "serve --for", "fleet script"):
            start = time.perf_counter()
            got = measure(lab, way, args.repeat, ticks)
            if got is not None:
                print(f"  {name:12} {way:13} {got[0]:17.2f} {got[1]:11.1f}x {time.perf_counter() - start:7.1f} "
                      f"{got[2]:13.2f} {got[3]:13.2f}")


if __name__ == "__main__":
    main()
