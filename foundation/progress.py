"""Progress on a terminal: one line redrawn in place, as ``labsim run`` and ``labsim sweep`` show it.

Both commands draw through ``StatusLine`` (a line written with a carriage return, rate-limited,
wiped when the work ends) and ``bar`` (``[#####     ]``), so that their bars look and behave
alike and a warning printed mid-run starts on a clean line.
"""
from __future__ import annotations

import sys
import time as clock
from typing import TextIO

WIDTH = 79  # characters a status line may take: an 80-column terminal never wraps it


def bar(fraction: float, width: int = 30) -> str:
    """``[#########                     ]`` for a fraction from 0 to 1."""
    return "[" + f"{'#' * int(max(0.0, min(1.0, fraction)) * width):<{width}}" + "]"


class StatusLine:
    """One terminal line, redrawn at most every ``every_s`` seconds (0: on every call)."""

    def __init__(self, stream: TextIO | None = None, every_s: float = 0.1):
        self.stream = stream if stream is not None else sys.stderr
        self.every_s = every_s
        self.started = clock.perf_counter()
        self.last = -float("inf")
        self.drawn = False

    def due(self) -> bool:
        """Whether a redraw now would show: not sooner than ``every_s`` after the last."""
        return clock.perf_counter() - self.last >= self.every_s

    def draw(self, text: str) -> None:
        self.last = clock.perf_counter()
        self.stream.write("\r" + text)
        self.stream.flush()
        self.drawn = True

    def clear(self) -> None:
        """Wipe the line, if anything was drawn, and leave the cursor at its start."""
        if self.drawn:
            self.stream.write("\r" + " " * WIDTH + "\r")
            self.stream.flush()
            self.drawn = False
