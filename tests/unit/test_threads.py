"""foundation/threads.py: one native thread per library in a run, unless LABSIM_THREADS says
otherwise (docs/sweep.md, "Threads"); the user's own BLAS variables are left alone."""
from __future__ import annotations

import subprocess
import sys

import pytest

from labsim.foundation import threads


@pytest.mark.parametrize(("value", "expected"), [
    (None, 1), ("", 1), ("1", 1), ("0", 0), ("3", 3), (" 2 ", 2), ("1024", 1024),
    ("1025", 1), ("-1", 1), ("two", 1), ("9" * 5000, 1), ("1e3", 1),
])
def test_labsim_threads_is_read_and_a_bad_value_is_the_default(monkeypatch, value: str | None, expected: int) -> None:
    if value is None:
        monkeypatch.delenv(threads.THREADS_ENV, raising=False)
    else:
        monkeypatch.setenv(threads.THREADS_ENV, value)
    assert threads.native_threads() == expected


def test_the_users_own_blas_setting_wins(monkeypatch) -> None:
    monkeypatch.delenv(threads.THREADS_ENV, raising=False)
    monkeypatch.setenv("OPENBLAS_NUM_THREADS", "4")
    for name in threads.BLAS_ENV[1:]:
        monkeypatch.delenv(name, raising=False)
    threads.limit_blas_threads()
    import os

    assert os.environ["OPENBLAS_NUM_THREADS"] == "4" and os.environ["OMP_NUM_THREADS"] == "1"


PROBE = """
import os, sys
from labsim.runtime.cli.main import main
main(['run', 'road_follow', '--set', 'seconds=0.2', '-q'])
import cv2
print(cv2.getNumThreads(), os.environ.get('OPENBLAS_NUM_THREADS'), len(os.listdir('/proc/self/task')))
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="counts threads in /proc")
@pytest.mark.parametrize(("value", "single"), [("", True), ("0", False)])
def test_a_camera_run_is_single_threaded_unless_asked(value: str, single: bool) -> None:
    env = {k: v for k, v in __import__("os").environ.items() if not k.endswith("_NUM_THREADS")}
    env[threads.THREADS_ENV] = value
    done = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True, env=env, timeout=300)
    cv2_threads, blas, tasks = done.stdout.split()
    if single:
        assert (cv2_threads, blas, tasks) == ("1", "1", "1"), done.stderr  # one thread in the whole process
    else:
        assert blas == "None" and (int(cv2_threads) > 1 or int(tasks) > 1 or _cores() == 1)


def _cores() -> int:
    import os

    return len(os.sched_getaffinity(0))
