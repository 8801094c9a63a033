"""How long `pytest behaviours/` takes (the labs' goldens as pytest items), as a user types it.

    python benchmarks/bench_pytest_goldens.py [--repeat 5]

Each round starts, in a fresh random order, new processes of ``python -m pytest behaviours/
-p no:cacheprovider -n 0 -q`` (every lab run and compared with its golden in one process),
the same with ``--collect-only`` (pytest's start, its plugins and the collection: what is not
a lab's run) and the same with ``--assert=plain`` (no module's asserts rewritten by pytest).
Prints for each the median wall time and CPU time (user + system of the process and its
children) and the peak memory, with the load average before and after. Goal (issue 30): the
first 30% under its 3.4 s wall of before, on a quiet machine. Run from anywhere: the
behaviours are this checkout's, and pytest starts in its root (its pyproject's options).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from compare import machine
from timed_child import load, print_medians, rounds

ROOT = Path(__file__).resolve().parent.parent


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    base = [sys.executable, "-m", "pytest", str(ROOT / "behaviours"), "-p", "no:cacheprovider", "-n", "0", "-q",
            "--rootdir", str(ROOT), "-c", str(ROOT / "pyproject.toml")]
    cases = {"pytest behaviours/": base, "  of which start and collection (--collect-only)": [*base, "--collect-only"],
             "pytest behaviours/ --assert=plain": [*base, "--assert=plain"]}
    print(machine())
    before = load()
    times = rounds(cases, args.repeat)
    print(f"medians of {args.repeat} rounds in random order ({before} before, {load()} after):")
    print_medians(times)


if __name__ == "__main__":
    main()
