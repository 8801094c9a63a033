"""The README's speed table: every row a ratio against a reference measured in the same run.

    python benchmarks/run_all.py [--markdown] [--repeat 5] [--minutes 25] [--rows wall,road,...]
    python benchmarks/run_all.py --markdown --write README.md   # replace the README's table

A figure measured one day and compared with one measured another day says more about the
machine's load than about the code (docs/decisions.md §27). So each row here has its sides,
run in this process, alternated in a fresh random order each round (``compare.alternate``):
labsim and the reference it is compared with, a plain pymunk loop, labsim's own internals
written by hand, the same run without the feature, or IR-SIM where it is installed. What a row
quotes is the median of the per-round ratios, in CPU time (this process's) and in wall time
(each side's whole call, set-up included), beside its goal, and whether the goal is met.
Absolute seconds are printed only as "on this machine", with the machine and the load at the
start and the end of the run. labsim has had no earlier release to compare with: a row against
the previous release is for when there is one.

The rows reuse the benchmarks' own sides (bench_wall.py, bench_road.py, bench_irsim.py), so the
hand-written loops are the ones their tests check against labsim's final poses.
"""
from __future__ import annotations

import argparse
import contextlib
import io
import os
import platform
import re
import statistics
import sys
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from compare import Times, alternate, pair_ratios, run_phase  # noqa: E402

ROOT = HERE.parent
WALL_LAB = ROOT / "behaviours" / "wall_follow.yaml"
MARKER = "<!-- speed table: python benchmarks/run_all.py --markdown -->\n"
TABLE = re.compile(re.escape(MARKER) + r".*?<!-- end speed table -->\n", re.S)


@dataclass(frozen=True)
class Goal:
    """``top / bottom`` must be at most (``most``) or at least (``least``) this ratio."""

    ratio: float
    most: bool = True

    def met(self, value: float) -> bool:
        return value <= self.ratio if self.most else value >= self.ratio

    def __str__(self) -> str:
        return f"{'<=' if self.most else '>='} {self.ratio:g}"


@dataclass(frozen=True)
class Row:
    """A measured ratio: what, top over bottom, its goal (None: a reference, no goal), and the sides' medians."""

    what: str
    top: str
    bottom: str
    goal: Goal | None
    cpu: float  # median of the per-round CPU ratios
    wall: float  # median of the per-round ratios of the whole calls' wall times
    seconds: dict[str, tuple[float, float]]  # side -> (median CPU s, median wall s of its whole call)


def ratios(times: Times, top: str, bottom: str) -> tuple[float, float]:
    return (statistics.median(pair_ratios(times[top], times[bottom])),
            statistics.median(pair_ratios(times.wall[top], times.wall[bottom])))


def medians(times: Times) -> dict[str, tuple[float, float]]:
    return {name: (statistics.median(times[name]), statistics.median(times.wall[name])) for name in times}


def measured(sides: dict[str, Callable[[], float]], repeat: int) -> Times:
    """``alternate`` after one untimed call of each side: the first call of a process builds what
    later ones find cached (the grammar's tables, a ground's texture, the kernel's first pages),
    which would otherwise count against whichever side the first round drew first."""
    for side in sides.values():
        side()
    return alternate(sides, repeat)


def own_cpu(run: Callable[[], tuple[float, object]]) -> Callable[[], float]:
    """A benchmark side that returns (CPU seconds, anything) as one that returns the seconds."""
    return lambda: run()[0]


def wall_rows(repeat: int, minutes: float) -> list[Row]:
    import bench_wall

    bench_wall.MINUTES[0] = minutes
    labsim, internals, plain = bench_wall.LABSIM, bench_wall.INTERNALS, bench_wall.PLAIN
    times = measured({internals: own_cpu(bench_wall.hand_run), plain: own_cpu(bench_wall.plain_run),
                       labsim: own_cpu(bench_wall.labsim_run)}, repeat)
    ticks = round(minutes * 1200)
    return [Row(f"wall lab, {ticks:,} ticks, run phase", labsim, internals, GOALS[labsim, internals],
                *ratios(times, labsim, internals), medians(times)),
            Row(f"wall lab, {ticks:,} ticks, run phase", labsim, plain, None, *ratios(times, labsim, plain),
                medians(times))]


def road_rows(repeat: int, minutes: float) -> list[Row]:
    import bench_road

    times = measured({"hand-written loop": own_cpu(bench_road.hand_run), "labsim": own_cpu(bench_road.labsim_run)},
                      repeat)
    return [Row("road lab, 5 robots x 600 ticks with cameras, run phase", "labsim", "hand-written loop",
                GOALS["labsim", "hand-written loop"], *ratios(times, "labsim", "hand-written loop"), medians(times))]


def feature_rows(repeat: int, minutes: float) -> list[Row]:
    """What a trace and seeded noise cost the wall lab: the same run with and without."""
    params = {"minutes": repr(minutes)}
    text = WALL_LAB.read_text(encoding="utf-8")
    plain = "pioneer: {model: pioneer_p3dx, at: random}"
    assert plain in text, "the wall lab's robot line changed; change this benchmark"
    tiny = "noise: {sonar: {std_m: 1.0e-9, dropout: 1.0e-9}, wheels: {std_rad_s: 1.0e-9, slip: 1.0e-9}}"
    with tempfile.TemporaryDirectory() as scratch:
        noisy = Path(scratch) / "wall_follow_noisy.yaml"
        noisy.write_text(text.replace(plain, plain[:-1] + ", " + tiny + "}"), encoding="utf-8")
        trace = Path(scratch) / "run.csv"
        times = measured({"plain": lambda: run_phase(WALL_LAB, params)[0],
                           "traced": lambda: run_phase(WALL_LAB, params, trace)[0],
                           "noise": lambda: run_phase(noisy, params)[0]}, repeat)
    ticks = round(minutes * 1200)
    return [Row(f"a trace's cost, wall lab, {ticks:,} ticks", "traced", "plain", GOALS["traced", "plain"],
                *ratios(times, "traced", "plain"), medians(times)),
            Row(f"seeded noise on sonars and wheels, wall lab, {ticks:,} ticks", "noise", "plain",
                GOALS["noise", "plain"], *ratios(times, "noise", "plain"), medians(times))]


def irsim_rows(repeat: int, minutes: float) -> list[Row]:
    """labsim against IR-SIM on one robot with 16 beams in walls_lab4, per step (lower is faster)."""
    os.environ.setdefault("MPLBACKEND", "Agg")
    try:
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            import irsim
    except ImportError:
        return []
    import bench_irsim

    with tempfile.TemporaryDirectory() as scratch:
        lab = Path(scratch) / "irsim_compare.yaml"
        lab.write_text(bench_irsim.BEHAVIOUR, encoding="utf-8")
        world = bench_irsim.irsim_world(lab, Path(scratch))

        steps: dict[str, int] = {}

        def per_step(name: str, run: Callable[..., tuple[float, int]], *args: object) -> Callable[[], float]:
            def once() -> float:
                elapsed, steps[name] = run(*args)
                return elapsed / steps[name]
            return once

        times = measured({"labsim": per_step("labsim", bench_irsim.labsim_steps, lab, 30000),
                           "labsim, 16 single rays": per_step("labsim, 16 single rays", bench_irsim.labsim_steps, lab,
                                                              30000, False, True),
                           "IR-SIM": per_step("IR-SIM", bench_irsim.irsim_steps, irsim, world, 2000)}, repeat)
    for name in times.wall:  # a whole call's wall time a step (its set-up included), as bench_irsim.py gives it
        times.wall[name] = [w / steps[name] for w in times.wall[name]]
    version = getattr(irsim, "__version__", "?")
    # IR-SIM's time a step over labsim's: how many times faster labsim is
    rows = []
    for name, what in (("labsim", "as the lab is (5-ray sonar cones: 80 rays)"),
                       ("labsim, 16 single rays", "with equal rays (one a sonar, as IR-SIM's 16 beams)")):
        rows.append(Row(f"one robot, 16 beams, walls_lab4, IR-SIM {version} headless, time a step, {what}", "IR-SIM",
                        name, GOALS["IR-SIM", name], *ratios(times, "IR-SIM", name), medians(times)))
    return rows


# each compared pair's goal (none: the pair is a reference); the README's table is held to these
GOALS: dict[tuple[str, str], Goal] = {
    ("labsim", "labsim's internals, by hand"): Goal(1.05),
    ("labsim", "hand-written loop"): Goal(1.05),
    ("traced", "plain"): Goal(1.5),
    ("noise", "plain"): Goal(1.25),
    ("IR-SIM", "labsim"): Goal(26, most=False),
    ("IR-SIM", "labsim, 16 single rays"): Goal(26, most=False),
}

ROWS: dict[str, Callable[[int, float], list[Row]]] = {
    "wall": wall_rows, "road": road_rows, "features": feature_rows, "irsim": irsim_rows}


def load() -> str:
    one, five, _ = os.getloadavg()
    return f"{one:.2f} {five:.2f}"


def seconds(value: float) -> str:
    return f"{value * 1e6:.1f} µs" if value < 0.01 else f"{value:.3g} s"


def markdown(rows: list[Row], header: str, skipped: list[str]) -> str:
    lines = [header, "",
             "| what | sides: top / bottom | CPU ratio | wall ratio | goal | on this machine: CPU / wall time a side |",
             "|---|---|---|---|---|---|"]
    for row in rows:
        goal = "reference" if row.goal is None else f"{row.goal}: {'met' if row.goal.met(row.cpu) else '**not met**'}"
        wall = "" if row.wall != row.wall else f"{row.wall:.3f}"
        sides = "; ".join(f"{name} {seconds(cpu)} / {seconds(wall_s)}" for name, (cpu, wall_s) in row.seconds.items()
                          if name in (row.top, row.bottom))
        lines.append(f"| {row.what} | {row.top} / {row.bottom} | {row.cpu:.3f} | {wall} | {goal} | {sides} |")
    lines += [f"| {what} | | | | | not measured: {why} |" for what, why in
              (s.split(": ", 1) for s in skipped)]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5, help="rounds of each row (default 5)")
    parser.add_argument("--minutes", type=float, default=25.0, help="the wall lab's simulated minutes (its own 25)")
    parser.add_argument("--rows", default=",".join(ROWS), help=f"which rows, of {', '.join(ROWS)}")
    parser.add_argument("--markdown", action="store_true", help="print the table as the README quotes it")
    parser.add_argument("--write", type=Path, help="with --markdown: replace the table in this Markdown file")
    args = parser.parse_args(argv)
    names = [n.strip() for n in args.rows.split(",") if n.strip()]
    unknown = [n for n in names if n not in ROWS]
    if unknown:
        parser.error(f"no such rows: {', '.join(unknown)} (rows: {', '.join(ROWS)})")
    started, load_before = datetime.now(timezone.utc), load()
    rows: list[Row] = []
    skipped: list[str] = []
    for name in names:
        got = ROWS[name](args.repeat, args.minutes)
        if not got and name == "irsim":
            skipped.append("against IR-SIM: IR-SIM is not installed (pip install -e '.[bench]')")
        rows += got
        print(f"{name}: done (load {load()})", file=sys.stderr)
    header = (f"Measured by `python benchmarks/run_all.py --markdown` on {started:%Y-%m-%d %H:%M} UTC: "
              f"{platform.system()} {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}; "
              f"load average {load_before} at the start and {load()} at the end (1, 5 min); {args.repeat} rounds "
              f"a row, its sides alternated in random order. Ratios are medians of the per-round ratios.")
    if not args.markdown:
        for row in rows:
            met = "" if row.goal is None else f"  goal {row.goal}: {'met' if row.goal.met(row.cpu) else 'NOT MET'}"
            print(f"{row.what}: {row.top} / {row.bottom} {row.cpu:.3f} CPU, {row.wall:.3f} wall{met}")
        print(header)
        return 0
    table = markdown(rows, header, skipped)
    if args.write is None:
        print(table, end="")
        return 0
    text = args.write.read_text(encoding="utf-8")
    if not TABLE.search(text):
        parser.error(f"{args.write} has no '{MARKER.strip()}' ... '<!-- end speed table -->' block")
    args.write.write_text(TABLE.sub(lambda m: MARKER + table + "<!-- end speed table -->\n", text), encoding="utf-8")
    print(f"wrote the speed table of {args.write}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
