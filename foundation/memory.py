"""The operating system's cap on a run's memory: the backstop under the checker's estimate.

The checker refuses a behaviour whose images would need more than the run's ``memory_mb``
budget (``labsim.dsl.analysis.budget``); what the estimate cannot see (a world's geometry, a backend's
own buffers, an estimate that is wrong) meets this cap instead. ``memory_cap`` lowers the
process's address space limit (``RLIMIT_AS``) for the span of a run, to what the process has
mapped already plus the budget plus ``HEADROOM_MB``, and puts the old limit back afterwards,
so a notebook that runs a behaviour keeps its own limit. An allocation past the cap fails
with ``MemoryError`` (or OpenCV's "insufficient memory"), which ``out_of_memory`` recognises
and the tick loop reports as labsim's own message. ``limit_memory`` is the one-way form a
sweep's worker process applies to itself (what it has mapped plus the run's megabytes). Where
the platform has no ``RLIMIT_AS`` (Windows; macOS does not enforce it) both do nothing and say
so by returning False: docs/security.md.
"""
from __future__ import annotations

import os
import threading
from collections.abc import Iterator
from contextlib import contextmanager, suppress

MB = 1024 * 1024
# what a run may map besides its images: the backend's buffers, a thread's malloc arena
# (64 MB of address space each, mostly never touched), OpenCV's worker threads' stacks
HEADROOM_MB = 1024


def limit_memory(memory_mb: int) -> bool:
    """Cap this process's address space for good (RLIMIT_AS), where the platform has it, at what
    it has mapped now plus memory_mb; 0 leaves it alone. What a sweep's local worker does first.
    A worker forked from a large process (a notebook's kernel, a test runner with its libraries
    and threads) has mapped more than a run's memory_mb already: capped at memory_mb itself, its
    stack could no longer grow and it crashed in the middle of Python code."""
    if memory_mb <= 0:
        return False
    mapped = _mapped_bytes()
    return _set_soft((mapped or 0) + memory_mb * MB) is not None


@contextmanager
def memory_cap(memory_mb: int) -> Iterator[bool]:
    """For the span of the ``with``: this process may map at most ``memory_mb`` + ``HEADROOM_MB``
    more than it has mapped now. Yields whether a cap is in force; 0 sets none.

    Only the main thread sets one: the limit is the whole process's, and runs in threads (a Dask
    worker's tasks) would set and restore it across each other; there the worker's own memory
    limit holds (docs/security.md, "Memory")."""
    mapped = _mapped_bytes() if threading.current_thread() is threading.main_thread() else None
    before = None if memory_mb <= 0 or mapped is None else _set_soft(mapped + (memory_mb + HEADROOM_MB) * MB)
    try:
        yield before is not None
    finally:
        if before is not None:
            _restore_soft(before)


def out_of_memory(error: BaseException) -> bool:
    """Whether an exception says an allocation failed: MemoryError, or OpenCV's cv2.error for
    one (OpenCV raises its own class, with "Insufficient memory" or "Failed to allocate")."""
    if isinstance(error, MemoryError):
        return True
    text = str(error)
    return type(error).__name__ == "error" and ("Insufficient memory" in text or "Failed to allocate" in text)


def _mapped_bytes() -> int | None:
    """The process's address space now (Linux's /proc/self/statm), or None where it cannot be read."""
    try:
        with open("/proc/self/statm", encoding="ascii") as f:
            pages = int(f.read().split()[0])
    except (OSError, ValueError, IndexError):
        return None
    return pages * os.sysconf("SC_PAGE_SIZE")


def _set_soft(limit: int) -> int | None:
    """Lower the soft RLIMIT_AS to ``limit`` (never raise it); the soft limit it had, or None
    when the platform has none or refuses."""
    try:
        import resource
    except ImportError:  # Windows
        return None
    soft, hard = resource.getrlimit(resource.RLIMIT_AS)
    if soft != resource.RLIM_INFINITY:
        limit = min(limit, soft)
    if hard != resource.RLIM_INFINITY:
        limit = min(limit, hard)
    try:
        resource.setrlimit(resource.RLIMIT_AS, (limit, hard))
    except (ValueError, OSError):
        return None
    return int(soft)


def _restore_soft(soft: int) -> None:
    import resource

    _, hard = resource.getrlimit(resource.RLIMIT_AS)
    with suppress(ValueError, OSError):  # raising a soft limit up to the hard one is allowed
        resource.setrlimit(resource.RLIMIT_AS, (soft, hard))
