"""The local executor of a sweep: the shared pool's worker processes, one run at a time each.

The pool itself (clean workers from the fork server, a run past its time limit or a dead
worker costing that one process, signals, workers that die with the sweep) is the batch layer's
``LocalBatch`` (runtime/batch.py), which ``labsim grade`` uses too. This module only says what
a sweep sends it (runtime/sweep/grid.py ``run_task`` of each ``Task``) and turns each outcome
into the sweep's ``Row``: a timeout, a dead worker or a run stopped by a signal become
``timeout``, ``runtime error`` and ``interrupted`` rows.
"""
from __future__ import annotations

from collections.abc import Generator

from labsim.runtime import batch
from labsim.runtime.batch import DIED, DONE, STOPPED, TIMEOUT, LocalBatch, Outcome, default_jobs
from labsim.runtime.sweep.grid import INTERRUPTED, RUNTIME_ERROR, Row, Task, row_of, run_task
from labsim.runtime.sweep.grid import TIMEOUT as TIMED_OUT

__all__ = ["LocalPool", "default_jobs", "warm_up"]
PRELOAD = ("labsim.runtime.sweep.grid",)  # what a worker runs, imported once in the fork server


def warm_up() -> None:
    """Start the fork server now (``batch.warm_up``), with the sweep's module in it."""
    batch.warm_up(PRELOAD)


class LocalPool:
    """Runs tasks in ``jobs`` processes; ``results`` yields a row per task as each finishes."""

    def __init__(self, jobs: int, timeout_s: float | None = None, memory_mb: int = 0):
        self.jobs = jobs
        self.timeout_s = timeout_s
        self.memory_mb = memory_mb  # each worker's address space (limit_memory); 0: none
        self._batch = LocalBatch(jobs, timeout_s, memory_mb, name="labsim-sweep-worker", preload=PRELOAD)
        self._tasks: list[Task] = []

    @property
    def in_flight(self) -> dict[int, Task]:
        """The tasks sent to a worker and not yet answered, by their index in the grid."""
        return {self._tasks[i].index: t for i, t in self._batch.in_flight.items()}

    def results(self, tasks: list[Task]) -> Generator[Row, None, None]:
        """Run every task; always stops every worker, also when the caller stops early."""
        self._tasks = tasks
        for outcome in self._batch.outcomes(run_task, tasks):
            yield self._row(outcome, "")

    def interrupt(self, why: str) -> list[Row]:
        """Stop the runs in progress and give their rows (``LocalBatch.interrupt``): a run ends as
        Ctrl-C ends ``labsim run``, its trace closed with its footer, its row interrupted with what
        it did so far. ``why`` ('Ctrl-C', 'SIGTERM', 'SIGHUP') goes in the rows' message."""
        return [self._row(o, why) for o in self._batch.interrupt(why)]

    def _row(self, o: Outcome, why: str) -> Row:
        task = self._tasks[o.index]
        if o.kind == DONE:
            if why and o.value["status"] == INTERRUPTED:
                o.value["message"] = f"stopped by {why}"
            return row_of(task, o.value, o.worker)
        status, message = {
            TIMEOUT: (TIMED_OUT, f"killed after --timeout-per-run {self.timeout_s:g} s"),
            DIED: (RUNTIME_ERROR, o.message),
            STOPPED: (INTERRUPTED, o.message),
        }[o.kind]
        return row_of(task, {"status": status, "message": message, "result": None, "task_time_s": o.wall_s},
                      o.worker)
