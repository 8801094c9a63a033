"""One run of a Dask sweep in a process of its own, started by the Dask task that carries it.

runtime/sweep/dask_pool.py sends each run to a Dask worker, whose task starts this module as a
child process (``python -m labsim.runtime.sweep.isolated``), hands it the run on standard input
and reads its result back: a run that exhausts memory or crashes the interpreter kills this
process, never the Dask worker, so it is that run's failure and no other run's (Dask would
otherwise retry every run the lost worker held, and give up on them too). The child ends its
run as Ctrl-C ends ``labsim run`` when it gets SIGTERM (the task's deadline, or the sweep's
Ctrl-C), and dies with the Dask worker (runtime/ending.py).

Only labsim's own objects cross the pipe, written by labsim on both sides; the run's own
output (``log()`` lines) goes to standard error, never into the result.
"""
from __future__ import annotations

import os
import pickle
import sys
from typing import Any

from labsim.foundation.files import allow
from labsim.foundation.threads import limit_blas_threads
from labsim.runtime.ending import Stopped, WorkerSignals, die_with_parent
from labsim.runtime.sweep.grid import INTERRUPTED


def main() -> int:
    """Read (runner, args, allowed folders, memory MB) on stdin; write the result dict on stdout."""
    limit_blas_threads()  # a Dask worker's environment is not the command line's
    out = os.fdopen(os.dup(sys.stdout.fileno()), "wb")
    os.dup2(sys.stderr.fileno(), sys.stdout.fileno())  # a print() of the run cannot reach the result
    signals = WorkerSignals()
    signals.install()
    die_with_parent()
    job: dict[str, Any] = pickle.load(sys.stdin.buffer)
    from labsim.foundation.memory import limit_memory

    allow(job["allowed"])
    limit_memory(job["memory_mb"])
    try:
        signals.armed = True
        result = job["runner"](*job["args"])
    except Stopped as e:  # before the run began, or after it ended: nothing to keep but the row
        result = {"status": INTERRUPTED, "result": None, "message": f"stopped by {e}", "task_time_s": 0.0}
    finally:
        signals.armed = False
    pickle.dump(result, out, protocol=pickle.HIGHEST_PROTOCOL)
    out.close()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
