"""What seeded noise costs: the wall lab with and without noise on its sonars and wheels.

    python benchmarks/bench_noise.py [--repeat 5] [--minutes 25]

Runs behaviours/wall_follow.yaml as it is, and with every noise model of the wall lab's robot
declared but tiny (1e-9 m of sonar jitter, a 1e-9 dropout, 1e-9 rad/s and 1e-9 slip on the
wheels): every random number is drawn and every wheel command re-sent each tick, as with real
noise, while the robot keeps close to the noiseless path, so both sides do the same simulation.
Prints the median CPU time (the process's: the runs are in it, with no children) and wall time of
each, alternated in random order, and the median of the per-round ratios (goal: noise <= 1.25 x
none), with the load average.
"""
from __future__ import annotations

import argparse
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from compare import alternate, machine, report, report_walls, run_phase

LAB = Path(__file__).resolve().parent.parent / "behaviours" / "wall_follow.yaml"
TINY = ("noise: {sonar: {std_m: 1.0e-9, dropout: 1.0e-9}, wheels: {std_rad_s: 1.0e-9, slip: 1.0e-9}}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--minutes", type=float, default=25)
    args = parser.parse_args()
    text = LAB.read_text()
    plain = "pioneer: {model: pioneer_p3dx, at: random}"
    assert plain in text
    with tempfile.TemporaryDirectory() as tmp:
        noisy = Path(tmp) / "wall_follow_noisy.yaml"
        noisy.write_text(text.replace(plain, plain[:-1] + ", " + TINY + "}"))
        ticks = [0]
        walls: dict[str, list[float]] = {"no noise": [], "noise": []}

        def side(path: Path, name: str) -> Callable[[], float]:
            def once_timed() -> float:
                elapsed, ticks[0] = run_phase(path, {"minutes": str(args.minutes)}, walls=walls[name])
                return elapsed
            return once_timed

        print(machine())
        times = alternate({"no noise": side(LAB, "no noise"), "noise": side(noisy, "noise")}, args.repeat)
    report(f"wall lab, {ticks[0]} ticks", times, ("noise", "no noise"), "<= 1.25")
    report_walls(walls)
    print(f"  {machine()[2:]}")

if __name__ == "__main__":
    main()
