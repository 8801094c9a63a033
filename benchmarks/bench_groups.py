"""Language 1.2's groups and counter on the wall lab: against the lab as written and a hand loop.

``benchmarks/wall_follow_groups.yaml`` is ``behaviours/wall_follow.yaml`` written with sonar
groups (``min([sonar5, sonar2])``, ``min(around)``) and a ``counter``; it computes the same
numbers, so all three sides end at the same pose. Goals: groups and counter within 1.05 x the
lab as written, and within 1.10 x the hand-written pymunk loop of ``bench_wall.py``.

    python benchmarks/bench_groups.py [--repeat 7] [--minutes 25]
"""
from __future__ import annotations

import argparse
from pathlib import Path

from bench_wall import LAB, MINUTES, hand_run
from compare import alternate, labsim_side, machine, report, same_poses

GROUPS = Path(__file__).resolve().parent / "wall_follow_groups.yaml"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=7)
    parser.add_argument("--minutes", type=float, default=25.0,
                        help="simulated minutes (a shorter try; the lab's 25 by default)")
    args = parser.parse_args()
    MINUTES[0] = args.minutes
    minutes = {"minutes": repr(args.minutes)}
    print(machine())
    poses: dict[str, list] = {}

    def side(name: str, run) -> object:
        def once() -> float:
            seconds, poses[name] = run()
            return seconds
        return once
    times = alternate({"hand-written loop": side("hand", hand_run),
                       "labsim, the lab": side("lab", lambda: labsim_side(LAB, 1, params=minutes)),
                       "labsim, groups + counter": side("groups", lambda: labsim_side(GROUPS, 1, params=minutes))},
                      args.repeat)
    ticks = f"wall lab, {round(args.minutes * 1200)} ticks"
    report(ticks, times, ("labsim, groups + counter", "labsim, the lab"), "<= 1.05")
    report(ticks, times, ("labsim, groups + counter", "hand-written loop"), "<= 1.10")
    same = same_poses(poses["groups"], poses["lab"]) and same_poses(poses["groups"], poses["hand"])
    print(f"  same final poses: {'yes' if same else 'NO'}")


if __name__ == "__main__":
    main()
