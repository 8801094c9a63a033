"""How long `pytest behaviours/` takes (the labs' goldens as pytest items), as a user types it.

    python benchmarks/bench_pytest_goldens.py [--repeat 5] [--against DIR]

Each round starts, in a fresh random order, new processes of ``python -m pytest behaviours/
-p no:cacheprovider -n 0 -q`` (every lab run and compared with its golden in one process),
the same with ``--collect-only`` (pytest's start, its plugins and the collection: what is not
a lab's run) and the same with ``--assert=plain`` (no module's asserts rewritten by pytest).
Prints for each the median wall time and CPU time (user + system of the process and its
children) and the peak memory, with the load average before and after. Goal (issue 30): the
first 30% under its 3.4 s wall of before, on a quiet machine. Run from anywhere: the
behaviours are this checkout's, and pytest starts in its root (its pyproject's options).
``--against DIR`` measures another checkout of labsim in the same rounds (a commit exported
with ``git archive COMMIT | tar -x -C DIR``; imported as ``labsim`` through a link to it), its
``pytest behaviours/`` and collection beside this one's: a comparison on a shared machine is
fair only side by side (benchmarks/RESULTS.md, old §63).
"""
from __future__ import annotations

import argparse
import os
import random
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from compare import machine
from timed_child import Timing, load, print_medians, timed

ROOT = Path(__file__).resolve().parent.parent


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--against", type=Path, help="another checkout of labsim, measured in the same rounds")
    args = parser.parse_args()
    base = _pytest(ROOT)
    cases: dict[str, tuple[list[str], dict[str, str] | None]] = {
        "pytest behaviours/": (base, None),
        "  of which start and collection (--collect-only)": ([*base, "--collect-only"], None),
        "pytest behaviours/ --assert=plain": ([*base, "--assert=plain"], None)}
    if args.against is not None:
        other = args.against.resolve()
        link = Path(tempfile.mkdtemp(prefix="labsim-against-"))
        (link / "labsim").symlink_to(other)
        env = {**os.environ, "PYTHONPATH": str(link)}
        cases[f"{other}: pytest behaviours/"] = (_pytest(other), env)
        newer = sorted(_goldens(ROOT) - _goldens(other))
        if newer:  # the same goldens on both sides as well: this tree's less those the other lacks
            cases[f"pytest behaviours/ without {', '.join(newer)} (the goldens both have)"] = (
                [*base, "-k", " and ".join(f"not {name}" for name in newer)], None)
        cases[f"{other}:   of which start and collection"] = ([*_pytest(other), "--collect-only"], env)
    print(machine())
    before = load()
    times: dict[str, list[Timing]] = {name: [] for name in cases}
    names = list(cases)
    for _ in range(args.repeat):  # each round in a fresh random order, as timed_child.rounds
        random.shuffle(names)
        for name in names:
            times[name].append(timed(*cases[name]))
    print(f"medians of {args.repeat} rounds in random order ({before} before, {load()} after):")
    print_medians(times)


def _goldens(root: Path) -> set[str]:
    """The behaviours with a golden trace in a checkout."""
    return {path.name.removesuffix(".golden.csv") for path in (root / "behaviours").glob("*.golden.csv")}


def _pytest(root: Path) -> list[str]:
    return [sys.executable, "-m", "pytest", str(root / "behaviours"), "-p", "no:cacheprovider", "-n", "0", "-q",
            "--rootdir", str(root), "-c", str(root / "pyproject.toml")]


if __name__ == "__main__":
    main()
