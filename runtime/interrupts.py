"""Ctrl-C and SIGTERM that land inside a simulator's C callback still end the run.

Python runs a signal handler between bytecodes, and during a physics step those may be the
bytecodes of a callback that the simulator's C code called: pymunk's collision handlers, or
the wheel drive the pymunk backend installs as a chipmunk velocity function. An exception
raised there cannot unwind through C: cffi reports it through ``sys.unraisablehook``
("Exception ignored from cffi callback", with a traceback on stderr) and the step goes on, so
the interrupt would be lost. While a run goes, ``CallbackInterrupts`` keeps such an interrupt
instead, and the tick loop raises it (``check``) between its blocks of ticks, where it unwinds
as it should. It costs nothing per tick: the loop checks once a block, and only an interrupt
reaches the hook. ``StopSignals`` is the other way, for a loop that is not a run's own (the
live view's server): the signal handlers only set a flag, which nothing can swallow.
"""
from __future__ import annotations

import signal
import sys
import threading
from types import TracebackType
from typing import Any


class CallbackInterrupts:
    """``with CallbackInterrupts() as caught: ... caught.check()``"""

    def __init__(self) -> None:
        self.pending: KeyboardInterrupt | None = None
        self._previous: Any = None

    def __enter__(self) -> CallbackInterrupts:
        if threading.current_thread() is threading.main_thread():  # signals reach the main thread only
            self._previous = sys.unraisablehook
            sys.unraisablehook = self._hook
        return self

    def __exit__(self, kind: type[BaseException] | None, value: BaseException | None,
                 tb: TracebackType | None) -> None:
        if self._previous is not None:
            sys.unraisablehook = self._previous
            self._previous = None
        if kind is None:
            self.check()  # the run ended in the block the interrupt came in: it was still asked for

    def _hook(self, unraisable: Any) -> None:
        if isinstance(unraisable.exc_value, KeyboardInterrupt):
            self.pending = self.pending or unraisable.exc_value
        else:
            self._previous(unraisable)

    def check(self) -> None:
        """Raise the interrupt a callback swallowed, if one did."""
        if self.pending is not None:
            pending, self.pending = self.pending, None
            raise pending


class StopSignals:
    """``with StopSignals() as stop: ... if stop.signum: ...``: SIGINT, SIGTERM and SIGHUP only
    set a flag that the caller's loop reads between its blocks of ticks.

    A server that ticks a run from an event loop (``labsim view``) cannot use
    ``CallbackInterrupts``: the exception a handler raises may unwind through the event loop,
    a web request or the page's message instead of the tick loop, and one raised inside a
    chipmunk callback is lost with nothing to raise it again. A handler that raises nothing
    loses nothing, wherever it runs. A second signal, once the first is seen, raises
    ``KeyboardInterrupt`` (someone insists). ``signum`` is the first signal caught, 0 before.
    """

    SIGNALS = ("SIGINT", "SIGTERM", "SIGHUP")  # SIGHUP: not on Windows

    def __init__(self) -> None:
        self.signum = 0
        self._previous: dict[int, Any] = {}

    def __enter__(self) -> StopSignals:
        if threading.current_thread() is threading.main_thread():  # signals reach the main thread only
            for name in self.SIGNALS:
                number = getattr(signal, name, None)
                if number is not None:
                    self._previous[number] = signal.signal(number, self._handle)
        return self

    def __exit__(self, kind: type[BaseException] | None, value: BaseException | None,
                 tb: TracebackType | None) -> None:
        for number, handler in self._previous.items():
            signal.signal(number, handler)
        self._previous = {}

    def _handle(self, signum: int, _frame: object) -> None:
        if self.signum:
            raise KeyboardInterrupt
        self.signum = signum
