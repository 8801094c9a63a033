"""Native threads per run: one each for OpenCV and the BLAS/OpenMP libraries, unless asked.

A run is one tick after another: OpenCV's parallel ``warpPerspective`` (the road lab's camera)
doubles its CPU for a few percent less wall time, and OpenBLAS starts a thread per core at
numpy's import that then sits idle; under ``labsim sweep -j 2`` each of two workers did so on
two cores. So the command line (runtime/cli/main.py, before numpy is imported) sets the BLAS
and OpenMP variables to one thread where the user has not set them, its processes (a sweep's
workers) inherit them, and the modules that import OpenCV for a run (backends/pymunk/camera.py,
dsl/library/images.py) set its thread count. ``LABSIM_THREADS=N`` gives N threads to each instead, and
``LABSIM_THREADS=0`` leaves every library its own default (docs/sweep.md, "Threads").
"""
from __future__ import annotations

import os
from typing import Any

THREADS_ENV = "LABSIM_THREADS"
# read by OpenBLAS, OpenMP (GNU and LLVM), MKL and Apple's Accelerate when they start
BLAS_ENV = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS", "VECLIB_MAXIMUM_THREADS")
MAX_THREADS = 1024


def native_threads() -> int:
    """Threads each native library may use in a run: LABSIM_THREADS, 1 by default; 0 for the
    libraries' own defaults. A value that is not a whole number from 0 to 1024 counts as unset."""
    text = os.environ.get(THREADS_ENV, "").strip()
    if text.isdigit() and len(text) <= 4 and int(text) <= MAX_THREADS:
        return int(text)
    return 1


def limit_blas_threads() -> None:
    """Set the BLAS and OpenMP thread variables the user left unset; they count only when read,
    so this must come before numpy (and so OpenBLAS) is imported."""
    n = native_threads()
    if n:
        for name in BLAS_ENV:
            os.environ.setdefault(name, str(n))


def limit_cv2_threads(cv2: Any) -> None:
    """OpenCV's own thread pool, for the process (cv2.setNumThreads)."""
    n = native_threads()
    if n:
        cv2.setNumThreads(n)
