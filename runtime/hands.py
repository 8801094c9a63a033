"""Hands on the world between two ticks: a robot put at a pose, a block moved, added or removed.

A live view (``labsim.runtime.view``) changes the world through ``Run.hand``, between two
ticks; ``HandsOn.apply`` sends each change through the backend, which refuses one that would
overlap a wall or a robot, and the run writes an accepted one in the trace's events column
(``place pioneer 1.5 -0.25 3.0``, ``block move 0 4.5 6.5``, ``block add 1 2.0 3.0 0.5 0.5``,
``block remove 0``), every number written so that it reads back as the same float.
``hand_events`` reads them back from a trace for ``labsim run --replay``, whose ``Inputs``
(``labsim.runtime.observers``) applies them at the same point of the tick as the live run did
(before the tick senses): a replayed run is the recorded one, row for row.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from labsim.backends.scene.world import World
from labsim.foundation.numbers import NumberError, to_float
from labsim.runtime.trace import Trace, TraceFormatError

Corners = tuple[tuple[float, float], ...]
PLACE = "place"  # an event: a robot put at a pose by hand, docs/trace-format.md
BLOCK = "block"  # an event: a block moved, added or removed by hand
BLOCK_SIZES_M = (0.05, 5.0)  # an added block's width and depth, m: smaller is lost, larger a wall
MAX_BLOCKS = 200  # blocks a run may have: every frame of a changed world carries them


@dataclass(frozen=True)
class Place:
    """A robot put at a pose, at rest: metres and radians."""

    robot: str
    x_m: float
    y_m: float
    heading_rad: float


@dataclass(frozen=True)
class BlockMove:
    """Block ``block`` moved, unturned, so that its centre (the mean of its corners) is at x, y."""

    block: int
    x_m: float
    y_m: float


@dataclass(frozen=True)
class BlockAdd:
    """A new block, number ``block`` (the next free one), an upright box centred at x, y."""

    block: int
    x_m: float
    y_m: float
    width_m: float  # along x
    depth_m: float  # along y


@dataclass(frozen=True)
class BlockRemove:
    block: int


Hand = Place | BlockMove | BlockAdd | BlockRemove
Hands = dict[int, list[Hand]]  # tick -> what hands did before it sensed, in order


def event_text(hand: Hand) -> str:
    """The events cell's text of a change (``repr`` of each number: it reads back exactly)."""
    if isinstance(hand, Place):
        return f"{PLACE} {hand.robot} {hand.x_m!r} {hand.y_m!r} {hand.heading_rad!r}"
    if isinstance(hand, BlockMove):
        return f"{BLOCK} move {hand.block} {hand.x_m!r} {hand.y_m!r}"
    if isinstance(hand, BlockAdd):
        return f"{BLOCK} add {hand.block} {hand.x_m!r} {hand.y_m!r} {hand.width_m!r} {hand.depth_m!r}"
    return f"{BLOCK} remove {hand.block}"


def parse_event(event: str) -> Hand | None:
    """The change an events cell's item records; None when it is not a hand's (a slider move, a
    metric, a log); ValueError when it is one but malformed."""
    parts = event.split(" ")
    if parts[0] == PLACE and len(parts) == 5:
        x, y, h = _numbers(parts[2:])
        return Place(parts[1], x, y, h)
    if parts[0] != BLOCK or event.startswith("log: "):
        if parts[0] == PLACE:
            raise ValueError("a placement is 'place ROBOT X Y HEADING'")
        return None
    shapes = {"move": 5, "add": 7, "remove": 3}
    if len(parts) < 3 or shapes.get(parts[1]) != len(parts) or not parts[2].isdigit() or len(parts[2]) > 6:
        raise ValueError("a block's event is 'block move N X Y', 'block add N X Y WIDTH DEPTH' or 'block remove N'")
    k = int(parts[2])
    if parts[1] == "remove":
        return BlockRemove(k)
    numbers = _numbers(parts[3:])
    return BlockMove(k, *numbers) if parts[1] == "move" else BlockAdd(k, *numbers)


def _numbers(texts: list[str]) -> list[float]:
    try:
        out = [to_float(t) for t in texts]
    except NumberError:
        raise ValueError("its numbers are not numbers") from None
    if not all(math.isfinite(v) for v in out):
        raise ValueError("its numbers must be finite")
    return out


def hand_events(trace: Trace) -> Hands:
    """What hands did in a trace's run (its events column), by tick, for a replay."""
    out: Hands = {}
    if "tick" not in trace.columns or "events" not in trace.columns:
        return out
    lines = trace.lines or range(3, 3 + len(trace.rows))
    seen: set[str] = set()
    for tick, text, line in zip(trace.column("tick"), trace.column("events"), lines):
        if tick in seen:  # every robot's row of a tick repeats what hands did: the first says it
            continue
        seen.add(tick)
        for event in text.split(";") if text else ():
            try:
                hand = parse_event(event)
            except ValueError as e:
                where = f"{trace.path}:{line}"
                raise TraceFormatError(f"{where}: event '{event[:60]}': {e}", str(trace.path), line) from None
            if hand is not None:
                out.setdefault(int(tick), []).append(hand)
    return out


class HandsOn:
    """The changes of one run, applied through its backend; ``blocks`` are the world's blocks
    as they stand (number -> corners, counter-clockwise), ``changed`` whether any moved."""

    def __init__(self, world: World, robots: Sequence[str], backend: object):
        self.world = world
        self.robots = {name: i for i, name in enumerate(robots)}
        self.backend = backend
        self.blocks: dict[int, Corners] = {i: b.corners for i, b in enumerate(world.blocks)}
        self.next_block = len(world.blocks)
        self.changed = False

    def apply(self, hand: Hand) -> str | None:
        """Make the change; None when done, else why not (nothing changed then)."""
        if isinstance(hand, Place):
            place = getattr(self.backend, "place", None)
            if hand.robot not in self.robots:
                return f"there is no robot '{hand.robot}'"
            if place is None:
                return f"the {getattr(self.backend, 'name', '?')} backend cannot move a robot"
            why: str | None = place(self.robots[hand.robot], hand.x_m, hand.y_m, hand.heading_rad)
            return why
        corners = self._corners(hand)
        if isinstance(corners, str):
            return corners
        set_block = getattr(self.backend, "set_block", None)
        if set_block is None:
            return f"the {getattr(self.backend, 'name', '?')} backend cannot change blocks"
        why = set_block(hand.block, corners)
        if why is None:
            if corners is None:
                del self.blocks[hand.block]
            else:
                self.blocks[hand.block] = corners
            self.next_block = max(self.next_block, hand.block + 1)
            self.changed = True
        return why

    def _corners(self, hand: BlockMove | BlockAdd | BlockRemove) -> Corners | str | None:
        """The block's corners after the change (None: removed), or why it cannot be."""
        if isinstance(hand, BlockAdd):
            if hand.block != self.next_block:
                return f"block {hand.block} is not the next new block ({self.next_block})"
            if len(self.blocks) >= MAX_BLOCKS:
                return f"a world has at most {MAX_BLOCKS} blocks"
            lo, hi = BLOCK_SIZES_M
            if not (lo <= hand.width_m <= hi and lo <= hand.depth_m <= hi):
                return f"a new block is {lo:g} to {hi:g} m wide and deep"
        elif hand.block not in self.blocks:
            return f"there is no block {hand.block}"
        if isinstance(hand, BlockRemove):
            return None
        x0, y0, x1, y1 = self.world.bounds
        if not (x0 <= hand.x_m <= x1 and y0 <= hand.y_m <= y1):
            return "it would be outside the world"
        if isinstance(hand, BlockAdd):
            w, d = hand.width_m / 2, hand.depth_m / 2
            x, y = hand.x_m, hand.y_m
            return ((x - w, y - d), (x + w, y - d), (x + w, y + d), (x - w, y + d))
        old = self.blocks[hand.block]
        cx, cy = centre(old)
        return tuple((c[0] - cx + hand.x_m, c[1] - cy + hand.y_m) for c in old)


def centre(corners: Corners) -> tuple[float, float]:
    """Where a block's centre is, as a move names it: the mean of its corners."""
    return sum(c[0] for c in corners) / len(corners), sum(c[1] for c in corners) / len(corners)
