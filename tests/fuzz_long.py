"""The long fuzz profile: at least 100,000 inputs through compile and a few ticks.

    LABSIM_FUZZ=long python tests/fuzz_long.py [--inputs 100000] [--jobs 2] [--seed 0]

Splits the inputs over ``--jobs`` processes, each running the strategies of
tests/fuzz_inputs.py (mutated shipped files, files generated from the grammar, and files of
format 1.2 with its constructs, two sevenths each: over 20,000 of these in the default 100,000)
under its own hypothesis seed (a seventh of them a sweep's ``--set``/``--seeds`` options instead),
generation only (no shrinking: a failure is recorded and the run goes on).
Prints the count, the rate in inputs per second, and each distinct failure (exception type and
where it was raised) with the first input that raised it, written under ``--out``. Exits 1 if
anything but the project's own errors was raised. The short profile is tests/hostile/test_fuzz.py.
"""
from __future__ import annotations

import argparse
import multiprocessing
import os
import sys
import tempfile
import time
import traceback
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from fuzz_inputs import (
    check_sweep_options,
    generated,
    generated_12,
    generated_member_wise,
    mutated,
    run_input,
    sweep_options,
)
from hypothesis import HealthCheck, Phase, given, seed, settings
from hypothesis import strategies as st

from labsim.backends.scene.world import World
from labsim.foundation.diagnostics import Report


def _where(e: BaseException) -> str:
    frames = traceback.extract_tb(e.__traceback__)
    last = frames[-1] if frames else None
    return f"{type(e).__name__} at {last.filename}:{last.lineno} ({last.name})" if last else type(e).__name__


def _cache_builtin_worlds() -> None:
    """Read each built-in world once per process: a behaviour names one in most inputs, and
    composing it again each time was half the cost of an input. The built-in worlds are fuzzed
    as inputs of their own (mutated), which this leaves alone."""
    import functools

    from labsim.backends.scene import world_file
    from labsim.backends.scene.world import BUILTIN_DIR

    read = world_file.load_world
    cached = functools.lru_cache(maxsize=None)(lambda path: read(path, Report()))

    def load_world(path: str | Path, report: Report) -> World | None:
        return cached(Path(path)) if Path(path).parent == BUILTIN_DIR else read(path, report)
    world_file.load_world = load_world  # type: ignore[assignment]


def _job(args: tuple[int, int, str]) -> tuple[int, dict[str, tuple[str, int, str]], float]:
    """Run ``count`` inputs under hypothesis seed ``job``; return (inputs, failures, seconds)."""
    job, count, out = args
    _cache_builtin_worlds()
    start = time.perf_counter()
    failures: dict[str, tuple[str, int, str]] = {}  # where -> (message, how many, input file)
    done = 0
    folder = Path(tempfile.mkdtemp(prefix=f"labsim-fuzz-{job}-"))

    def one(data: bytes | tuple, world: bool | None) -> None:
        nonlocal done
        done += 1
        if done % 2000 == 0:
            print(f"job {job}: {done} inputs, {done / (time.perf_counter() - start):.0f}/s, "
                  f"{sum(n for _, n, _ in failures.values())} failed", file=sys.stderr, flush=True)
        try:
            if isinstance(data, tuple):  # a sweep's options
                check_sweep_options(*data)
            else:
                run_input(folder, data, bool(world))
        except Exception as e:  # anything but ALLOWED is what we look for
            key = _where(e)
            if key not in failures:
                name = Path(out) / f"failure-{job}-{len(failures)}{'-world' if world else ''}.yaml"
                name.write_bytes(data if isinstance(data, bytes) else repr(data).encode())
                failures[key] = (str(e)[:200], 0, str(name))
            message, n, name_ = failures[key]
            failures[key] = (message, n + 1, name_)

    inputs = st.one_of(mutated().map(lambda m: (m[1], m[2])), mutated().map(lambda m: (m[1], m[2])),
                       generated().map(lambda text: (text.encode(), False)),
                       generated().map(lambda text: (text.encode(), False)),
                       generated_12().map(lambda text: (text.encode(), False)),
                       generated_12().map(lambda text: (text.encode(), False)),
                       generated_member_wise().map(lambda text: (text.encode(), False)),
                       sweep_options().map(lambda o: (o, None)))

    @seed(job)
    @settings(max_examples=count, database=None, deadline=None, phases=[Phase.generate],
              suppress_health_check=list(HealthCheck))
    @given(inputs)
    def fuzz(item: tuple[bytes | tuple, bool | None]) -> None:
        one(*item)

    while done < count:  # hypothesis may stop a little short of max_examples; top it up
        before = done
        fuzz()
        if done == before:
            break
    return done, failures, time.perf_counter() - start


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--inputs", type=int, default=100_000 if os.environ.get("LABSIM_FUZZ") == "long" else 2_000)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", default="fuzz-failures")
    a = parser.parse_args()
    Path(a.out).mkdir(exist_ok=True)
    per = -(-a.inputs // a.jobs)
    start = time.perf_counter()
    with multiprocessing.Pool(a.jobs) as pool:
        results = pool.map(_job, [(a.seed * 1000 + j, per, a.out) for j in range(a.jobs)], chunksize=1)
    wall = time.perf_counter() - start
    total = sum(r[0] for r in results)
    merged: dict[str, tuple[str, int, str]] = {}
    for _, failures, _ in results:
        for key, (message, n, name) in failures.items():
            old = merged.get(key)
            merged[key] = (message, n + (old[1] if old else 0), old[2] if old else name)
    failed = sum(n for _, n, _ in merged.values())
    print(f"{total} inputs in {wall:.0f} s on {a.jobs} processes: {total / wall:.0f} inputs/s "
          f"({total / sum(r[2] for r in results):.0f} per process-second); {failed} failed")
    for key, (message, n, name) in sorted(merged.items()):
        print(f"  {n:6d} x {key}: {message}\n         first input: {name}")
    return 1 if merged else 0


if __name__ == "__main__":
    sys.exit(main())
