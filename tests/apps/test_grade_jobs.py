"""A graded submission is one job for all its seeds (runtime/grade/runs.py): compiled once, each
seed's run the same as when compiled alone, and a job the pool killed or lost is each seed's row."""
from __future__ import annotations

from pathlib import Path

from helpers import FIXTURES

import labsim.dsl.compile as compiling
from labsim.foundation.files import allowing
from labsim.foundation.limits import Budgets
from labsim.runtime.batch import DIED, DONE, STOPPED, TIMEOUT, Outcome
from labsim.runtime.grade.driver import _Runs
from labsim.runtime.grade.runs import CRASHED, NOT_COMPILED, RAN, TIMED_OUT, SeedRun, make_job, run_job

REFERENCE = FIXTURES / "grading" / "reference.yaml"
PARAMS = {"minutes": "0.1"}


def job(path: Path, seeds: tuple[int, ...]):  # type: ignore[no-untyped-def]
    return make_job("s", path, None, seeds, PARAMS, Budgets(), 60.0, pictures=None)


def test_a_students_seeds_share_one_compile_and_each_run_is_that_seeds_own(monkeypatch) -> None:
    calls = []
    real = compiling.generate
    monkeypatch.setattr(compiling, "generate", lambda *a: calls.append(a) or real(*a))
    with allowing(str(FIXTURES)):
        together = run_job(job(REFERENCE, (1, 2, 3)))
        assert len(calls) == 1
        alone = [run_job(job(REFERENCE, (seed,)))[0] for seed in (1, 2, 3)]
    assert [r.seed for r in together] == [1, 2, 3] and {r.status for r in together} == {RAN}
    assert [(r.metrics, r.ticks, r.collisions, r.faults) for r in together] == \
        [(r.metrics, r.ticks, r.collisions, r.faults) for r in alone]
    assert len({tuple(r.metrics.items()) for r in together}) == 3  # the robot starts at random: each seed its own


def test_a_file_that_does_not_compile_is_every_seeds_row(tmp_path: Path) -> None:
    broken = tmp_path / "broken.yaml"
    broken.write_text(REFERENCE.read_text().replace(" then goto", " than goto", 1))
    with allowing(str(tmp_path)):
        runs = run_job(job(broken, (1, 2)))
    assert [(r.seed, r.status) for r in runs] == [(1, NOT_COMPILED), (2, NOT_COMPILED)]
    assert runs[0].message.startswith(f"{broken}:")  # the path as the teacher gave it, not the scratch folder's


def test_a_job_the_pool_killed_or_lost_is_each_seeds_row_and_a_stopped_one_none() -> None:
    jobs = [job(REFERENCE, (1, 2)) for _ in range(4)]
    finished: list[tuple[str, list[SeedRun]]] = []
    runs = _Runs(jobs, 30.0, lambda student, mine: finished.append((student, mine)))
    runs.take(Outcome(0, TIMEOUT, message="killed after its time limit of 65 s", wall_s=65.0))
    runs.take(Outcome(1, DIED, message="the worker process died while running it (exit code -11)"))
    runs.take(Outcome(2, STOPPED, message="stopped by Ctrl-C"))
    runs.take(Outcome(3, DONE, value=(SeedRun(1, RAN), SeedRun(2, "interrupted"))))
    timed_out, died, stopped, half = runs.done
    assert [(r.seed, r.status) for r in timed_out] == [(1, TIMED_OUT), (2, TIMED_OUT)]
    assert timed_out[0].message == "it did not stop at its time limit of 30 s a run, and was killed"
    assert [(r.seed, r.status, r.message) for r in died] == [
        (1, CRASHED, "the worker process died while running it (exit code -11)"),
        (2, CRASHED, "the worker process died while running it (exit code -11)")]
    assert stopped == [] and [r.seed for r in half] == [1]  # a run a signal stopped is no result
    assert runs.count == 5 and len(finished) == 2  # the two with both seeds' rows are cached at once
