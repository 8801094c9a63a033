"""What every view of a run shares: the controls, the pacing and the page's messages.

A ``Session`` is one thing being watched, a live run (``labsim.runtime.view.live``) or a
recorded trace (``labsim.runtime.view.replay``). The server (``labsim.runtime.view.server``)
owns one and calls ``catch_up`` about 30 times a second: it runs the ticks that are due, so
that simulated time follows wall time times the speed the page set (or, at "as fast as it
goes", runs for most of a frame's interval), and then sends one frame. Every tick is
computed; only frames are dropped. ``handle`` checks and applies one message from a page;
anything it cannot use raises ``BadMessage``, which the server logs and ignores.
"""
from __future__ import annotations

import math
import time
from collections import deque
from collections.abc import Callable
from contextlib import AbstractContextManager, nullcontext
from typing import Any

from labsim.runtime.view.frames import FRAME_INTERVAL_S, Json, message

MAX_SPEED = 1000.0  # beyond this a number is not a speed anyone means; "max" is the way to ask
CHECK_EVERY = 16  # ticks between looks at the clock while catching up, at first (see ``Session.catch_up``)
CHECK_MOST = 256  # and at most, for a run whose ticks take a few microseconds
CHECK_S = 0.002  # the time a stretch of ticks between two looks at the clock aims at
MAX_NAME = 200  # longest slider or parameter name a message may carry


class BadMessage(ValueError):
    """A page's message that cannot be used: malformed, unknown, or out of range."""


class ChangeRefused(Exception):
    """A page's change (a parameter, an edit) that the checks refused; the message lists why,
    ``places`` where in the edited text (line, column, message) for the page's editor."""

    def __init__(self, diagnostics: list[str], places: list[dict[str, object]] | None = None):
        super().__init__("\n".join(diagnostics))
        self.diagnostics = diagnostics
        self.places = places or []


class Pacer:
    """How many ticks are due: simulated time = wall time x speed since the last anchor.

    ``speed`` None means as fast as it goes. Times are the caller's clock, in seconds, so
    tests drive it with a clock of their own.
    """

    def __init__(self, dt_s: float):
        self.dt_s = dt_s
        self.speed: float | None = 1.0
        self._wall = 0.0
        self._tick = 0

    def anchor(self, now: float, tick: int) -> None:
        self._wall, self._tick = now, tick

    def due(self, now: float, tick: int) -> int:
        """Ticks to run now to be on time (0 when ahead); unbounded at "max"."""
        if self.speed is None:
            return 1 << 62
        target = self._tick + math.floor((now - self._wall) * self.speed / self.dt_s + 1e-9)
        return max(0, target - tick)


class Session:
    """One watched run; subclasses provide the ticks and the documents. See the module."""

    def __init__(self, dt_s: float, clock: Callable[[], float] = time.perf_counter):
        self.clock = clock
        self.pacer = Pacer(dt_s)
        self.playing = False
        self._rate: deque[tuple[float, int]] = deque(maxlen=64)  # (wall s, tick) samples
        self.stop: Any = None  # the server's StopSignals: a signal caught ends a catch-up between blocks
        self._stretch = CHECK_EVERY  # ticks run between two looks at the clock

    # -- what subclasses provide --------------------------------------------------------
    @property
    def dt_s(self) -> float:
        return self.pacer.dt_s

    @property
    def tick(self) -> int:
        raise NotImplementedError

    @property
    def finished(self) -> bool:
        raise NotImplementedError

    @property
    def shown_tick(self) -> int:
        """The tick whose values a frame shows (a replay's row; a live run's last tick run)."""
        return self.tick

    @property
    def ran(self) -> int:
        """Ticks shown so far, this one included (0: a live run that has not ticked yet)."""
        return self.tick + 1

    def advance(self, n: int) -> int:
        """Run up to n ticks; how many ran (fewer once the run has ended)."""
        raise NotImplementedError

    def scene(self) -> Json:
        raise NotImplementedError

    def frame(self, take: bool = True) -> Json:
        """The frame now; ``take`` False leaves the path points and chart samples since the last
        frame for the next one (a page that joins while others watch)."""
        raise NotImplementedError

    def history(self) -> Json:
        """The ``history`` message: what the frames so far drew (docs/view.md)."""
        return message("history", tick=self.shown_tick, robots=[])

    def images(self, robot: int) -> Json | None:
        """The robot's camera and derived images for the page, or None when it has none."""
        return None

    def restart(self) -> None:
        raise NotImplementedError

    def close(self) -> None:
        """Release the run (a live run's trace is closed and kept)."""

    # -- pacing -----------------------------------------------------------------------------
    def catch_up(self, budget_s: float = FRAME_INTERVAL_S * 0.8) -> int:
        """Run the ticks that are due, for at most about ``budget_s`` of wall time.

        A run that cannot keep up drops its backlog (re-anchors), so that a slow stretch does
        not turn into a burst later: the real-time factor shows it instead. The clock is looked
        at about every ``CHECK_S``: the stretch of ticks between two looks doubles while it takes
        less than half that and halves while it takes more (16 ticks a look were a tenth of the
        view's own cost a tick on the wall lab; 256 of a camera lab's would overrun a frame).
        """
        if not self.playing or self.finished:
            self.note_rate()
            return 0
        start = last = self.clock()
        due = self.pacer.due(start, self.tick)
        ran = 0
        with self.ticking():
            while ran < due:
                n = self.advance(min(self._stretch, due - ran))
                ran += n
                if n == 0 or self.finished or not self.playing:  # ended, or paused on a breakpoint
                    self.playing = False
                    break
                if self.stop is not None and self.stop.signum:  # Ctrl-C, SIGTERM: the server ends
                    break
                now = self.clock()
                if now - last < CHECK_S / 2 and n == self._stretch:
                    self._stretch = min(CHECK_MOST, 2 * n)
                elif now - last > CHECK_S:
                    self._stretch = max(1, self._stretch // 2)
                last = now
                if now - start >= budget_s:
                    if self.pacer.speed is not None:
                        self.pacer.anchor(now, self.tick)
                    break
        self.note_rate()
        return ran

    def ticking(self) -> AbstractContextManager[object]:
        """What holds around a frame's worth of ``advance`` calls (a live run's memory cap:
        set once a frame, not once every few ticks)."""
        return nullcontext()

    def note_rate(self) -> None:
        self._rate.append((self.clock(), self.tick))

    def real_time_factor(self) -> float | None:
        """Simulated over wall time across the last second or so; None before there is any."""
        if len(self._rate) < 2:
            return None
        now, tick = self._rate[-1]
        then, before = next(((t, k) for t, k in self._rate if now - t <= 1.5), self._rate[-1])
        if now - then <= 0:
            return None
        return (tick - before) * self.dt_s / (now - then)

    def play(self) -> None:
        if not self.finished:
            self.playing = True
            self.pacer.anchor(self.clock(), self.tick)

    def set_speed(self, speed: float | None) -> None:
        self.pacer.speed = speed
        self.pacer.anchor(self.clock(), self.tick)

    def controls(self) -> Json:
        """The frame's fields every session has."""
        rtf = self.real_time_factor() if self.playing else None
        shown = self.shown_tick
        return {"tick": shown, "time": round(shown * self.dt_s, 9), "ran": self.ran, "playing": self.playing,
                "finished": self.finished, "speed": self.pacer.speed if self.pacer.speed is not None else "max",
                "rtf": rtf if rtf is not None and math.isfinite(rtf) else None}

    # -- the page's messages ----------------------------------------------------------------
    def handle(self, msg: Any) -> bool:
        """Apply one decoded message through ``MESSAGES``; True when the scene changed (a
        restart) and every page needs it again. Raises BadMessage for anything malformed, out of
        range, or not for this kind of session."""
        if not isinstance(msg, dict):
            raise BadMessage("a message is a JSON object")
        kind = msg.get("type")
        if not isinstance(kind, str) or kind not in MESSAGES:
            raise BadMessage(f"unknown message type '{str(kind)[:40]}'")
        method = MESSAGES[kind][0]
        handler = getattr(self, method, None) if method else None
        if handler is None:
            if method is None:
                return False  # the server's own (select, ack): nothing of the run's
            raise BadMessage(f"a {self.mode} session takes no '{kind}' messages")
        return bool(handler(msg))

    mode = "live"  # what a page is watching: "live" or "replay" (the scene's mode)

    def on_play(self, msg: dict) -> bool:
        self.play()
        return False

    def on_pause(self, msg: dict) -> bool:
        self.playing = False
        return False

    def on_step(self, msg: dict) -> bool:
        self.playing = False
        self.advance(1)
        return False

    def on_speed(self, msg: dict) -> bool:
        self.set_speed(_speed(msg.get("value")))
        return False

    def on_restart(self, msg: dict) -> bool:
        self.restart()
        return True


# Every message a page sends, in one place: its type, the session's method that applies it (None:
# the server's own, per page), and what it carries (docs/view.md, "Messages"). A session without
# the method (a replay has no sliders; a live run no seek) refuses the message as malformed.
MESSAGES: dict[str, tuple[str | None, str]] = {
    "play": ("on_play", "{}"),
    "pause": ("on_pause", "{}"),
    "step": ("on_step", "{} (one tick, then paused)"),
    "speed": ("on_speed", '{"value": a number in (0, 1000] or "max"}'),
    "restart": ("on_restart", "{} (a replay: back to its first row)"),
    "select": (None, '{"robot": an index} (whose images this page gets)'),
    "ack": (None, "{} (this page drew the last frame)"),
    "slider": ("on_slider", '{"name": a slider, "value": a finite number}'),
    "params": ("on_params", '{"values": {name: a number or its text}}'),
    "timeline": ("on_timeline", '{"on": true or false}'),
    "recheck": ("on_recheck", "{}"),
    "apply": ("on_apply", '{"text": the file, at most 60,000 characters}'),
    "save": ("on_save", '{"text": the file, at most 60,000 characters}'),
    "place": ("on_place", '{"robot": an index, "x": m, "y": m, "heading": rad}'),
    "block": ("on_block", '{"op": "move" | "add" | "remove", "block": a number, "x": m, "y": m, ...}'),
    "break": ("on_break", '{"add": a breakpoint as --break takes it} or {"remove": an index}'),
    "seek": ("on_seek", '{"tick": a number} (a replay)'),
}


def _speed(value: object) -> float | None:
    if value == "max":
        return None
    v = finite(value, "speed")
    if not 0 < v <= MAX_SPEED:
        raise BadMessage(f"speed {v:g} is out of range (more than 0, at most {MAX_SPEED:g}, or \"max\")")
    return v


def finite(value: object, what: str) -> float:
    """A finite number from a message, or BadMessage."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise BadMessage(f"{what} must be a finite number")
    return float(value)


def name(value: object, what: str) -> str:
    """A short string from a message, or BadMessage."""
    if not isinstance(value, str) or not value or len(value) > MAX_NAME:
        raise BadMessage(f"{what} must be a name")
    return value
