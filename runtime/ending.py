"""How a batch and its workers end: the signals each one handles, and workers that die with the batch.

Part of the batch layer (runtime/batch.py) that ``labsim sweep`` and ``labsim grade`` share.
The application's driver turns SIGTERM and SIGHUP (a closed terminal, a logout) into the
Ctrl-C it already handles (``batch_signals``): the runs in progress are asked to stop, and
everything done so far is written (docs/sweep.md, "Ending a sweep"; docs/grading.md). A local
worker ignores Ctrl-C (the parent stops it) and takes SIGTERM and SIGHUP as the end of its
run: the tick loop ends as for Ctrl-C, so the run's trace gets its footer, and the worker sends
its value back and exits. On Linux a worker also asks the kernel for SIGTERM when the process
that forked it dies (``PR_SET_PDEATHSIG``): a batch killed with SIGKILL, whose own handlers
never run, still takes its workers with it, each closing its trace.
"""
from __future__ import annotations

import contextlib
import ctypes
import os
import signal
import sys
import threading
from collections.abc import Iterator
from types import FrameType

PR_SET_PDEATHSIG = 1  # linux/prctl.h
# what ends a batch, and what each one tells the shell: 128 + the signal's number, as a shell
# reports a process that signal ended (foundation/exits.py has 130 and 143)
ENDINGS: dict[int, str] = {signal.SIGINT: "Ctrl-C", signal.SIGTERM: "SIGTERM"}
if hasattr(signal, "SIGHUP"):  # not on Windows
    ENDINGS[signal.SIGHUP] = "SIGHUP"


class Stopped(KeyboardInterrupt):
    """A signal that ends a batch or a worker's run, handled as Ctrl-C is; ``signum`` says which."""

    def __init__(self, signum: int = signal.SIGINT) -> None:
        super().__init__(ENDINGS.get(signum, f"signal {signum}"))
        self.signum = signum


def ending(e: KeyboardInterrupt) -> tuple[int, str]:
    """The signal behind an interrupt and its name: Ctrl-C unless a Stopped says otherwise, or
    the command line's own SIGTERM (its class is named Terminated; an application may not import it)."""
    if isinstance(e, Stopped):
        return e.signum, ENDINGS.get(e.signum, str(e))
    if type(e).__name__ == "Terminated":
        return signal.SIGTERM, "SIGTERM"
    return signal.SIGINT, "Ctrl-C"


def exit_code(signum: int) -> int:
    return 128 + int(signum)


def _raise(signum: int, frame: FrameType | None) -> None:
    raise Stopped(signum)


def _hangup_and_term() -> list[int]:
    return [s for s in ENDINGS if s != signal.SIGINT]


@contextlib.contextmanager
def batch_signals() -> Iterator[None]:
    """In the batch's parent process: SIGTERM and SIGHUP raise Stopped while the batch runs, as Ctrl-C
    raises KeyboardInterrupt; the previous handlers come back after."""
    if threading.current_thread() is not threading.main_thread():  # signals reach the main thread only
        yield
        return
    previous = {s: signal.signal(s, _raise) for s in _hangup_and_term()}
    try:
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)


@contextlib.contextmanager
def deaf() -> Iterator[None]:
    """Every ending signal ignored for a short while: the time a batch gives its workers to
    close their traces and send their rows, which a second Ctrl-C must not cut short."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {s: signal.signal(s, signal.SIG_IGN) for s in ENDINGS}
    try:
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)


class WorkerSignals:
    """In a worker: SIGTERM and SIGHUP end the run in progress (raised as Stopped while ``armed``)
    or, between runs, the worker (``asked``). Disarmed while a row is sent, so that a signal
    never cuts a message to the batch in half."""

    def __init__(self) -> None:
        self.asked: int = 0  # the signal that asked this worker to stop; 0: none
        self.armed = False

    def install(self) -> None:
        signal.signal(signal.SIGINT, signal.SIG_IGN)  # the terminal's Ctrl-C: the batch stops its workers
        for s in _hangup_and_term():
            signal.signal(s, self._handle)

    def _handle(self, signum: int, frame: FrameType | None) -> None:
        self.asked = self.asked or signum
        if self.armed:
            self.armed = False  # once: a second signal must not cut the trace's footer
            raise Stopped(signum)


def die_with_parent() -> bool:
    """Ask the kernel for SIGTERM when this process's parent dies (Linux), and leave at once if
    it died already (before the request). False where the platform has no such request.

    A worker's parent is multiprocessing's fork server, which exits when the batch's end of a
    pipe closes, unless a worker holds a copy of that end (every forked child is given one, to
    start processes of its own, which a worker never does): the worker closes its copy first,
    or a killed batch's busy workers would keep the fork server, and so themselves, alive."""
    _let_go_of_the_fork_server()
    if not sys.platform.startswith("linux"):
        return False
    parent = os.getppid()
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        if libc.prctl(PR_SET_PDEATHSIG, int(signal.SIGTERM), 0, 0, 0) != 0:
            return False
    except (OSError, AttributeError):  # no C library to ask, or no prctl in it
        return False
    if os.getppid() != parent or parent == 1:  # orphaned before the request took hold
        os.kill(os.getpid(), signal.SIGTERM)
    return True


def _let_go_of_the_fork_server() -> None:
    from multiprocessing import forkserver

    server = getattr(forkserver, "_forkserver", None)
    fd = getattr(server, "_forkserver_alive_fd", None)
    if isinstance(fd, int):  # a child of the fork server (multiprocessing's own name, CPython 3.8-3.13)
        with contextlib.suppress(OSError):
            os.close(fd)
        server._forkserver_alive_fd = None  # type: ignore[union-attr]
