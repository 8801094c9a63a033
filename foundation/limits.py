"""The sizes labsim accepts: fixed ranges for what files say, and per-run budgets.

Two kinds of limit, both written down in docs/worlds.md, docs/language.md and docs/security.md:

* **Ranges** are part of the file formats and never change with an option: a coordinate
  beyond ``MAX_COORD_M`` or a time step below ``MIN_DT_S`` is a mistake in the file, reported
  at its position. They keep every later computation finite and every loop short (an arc of
  radius 1e12 would need 10^8 chords; one of 1e15 is a division by zero).
* **Budgets** bound what one run may cost (robots, camera pixels, world segments, ticks, trace
  size, memory). Their defaults are generous for every lab and every world shipped; a teacher running
  a class's files raises one with ``--budget NAME=VALUE`` (``Budgets.parse``). A student's file
  cannot raise its own budget: that is the point of having one.

The scene layer holds both because the world reader checks the ranges and every layer above
reads the budgets; nothing here imports the rest of labsim.
"""
from __future__ import annotations

from dataclasses import dataclass, fields, replace

# --- ranges: what a file may say -----------------------------------------------------------------
MAX_COORD_M = 10_000.0  # |x|, |y| of any point in a world or a start pose: a 20 km square
MAX_SIZE_M = 2 * MAX_COORD_M  # a block's, patch's or line's extent; a wall's thickness below
MAX_THICKNESS_M = 10.0  # a wall's thickness
MIN_SIZE_M = 1e-4  # 0.1 mm: anything smaller is a typo, and a zero divides
MAX_RADIUS_M = MAX_COORD_M  # an arc's radius; also above MIN_SIZE_M
# one arc's chords: enough for 0.5 mm from the circle up to a radius of 1.6 km; a larger arc
# takes this many and strays from its circle by at most 3 mm (at radius 10 km)
MAX_ARC_CHORDS = 4096
MIN_DT_S = 1e-4  # the smallest time step, 0.1 ms: 10,000 ticks for every simulated second
MAX_DT_S = 1.0


@dataclass(frozen=True)
class Budgets:
    """What one run may cost. A run past one stops with a message (exit 2), its trace kept.

    The defaults fit every shipped lab and world with room to spare; see docs/security.md.
    """

    robots: int = 1000  # robots in one run (each group's count is at most 100)
    camera_px: int = 4_000_000  # camera pixels rendered per tick, all robots together
    segments: int = 100_000  # world geometry: wall, block and road segments after expanding arcs
    ticks: int = 200_000  # ticks per run: 10,000 s (2 h 47 min) simulated at the default dt 0.05
    trace_mb: int = 500  # a trace file's size, in megabytes
    # a tick's image memory, in megabytes (10**6 bytes): the checker's estimate is held against it,
    # and the run's address space may grow by this plus a headroom (labsim.foundation.memory)
    memory_mb: int = 1000
    warn_wall_s: int = 300  # warn once when a run is on course to take longer than this (wall clock)

    @staticmethod
    def names() -> tuple[str, ...]:
        return tuple(f.name for f in fields(Budgets))

    def parse(self, pairs: list[str]) -> tuple[Budgets, list[tuple[str, str]]]:
        """This budget with ``NAME=VALUE`` settings applied, and (where, message) for each bad one."""
        out, problems = self, []
        for pair in pairs:
            name, eq, text = pair.partition("=")
            name = name.strip()
            if not eq or name not in self.names():
                problems.append((f"--budget {pair}", f"give NAME=VALUE with NAME one of {', '.join(self.names())}"))
                continue
            value = _whole(text.strip())
            if value is None:
                problems.append((f"--budget {pair}", "the value is a whole number from 0 to 10**12"))
                continue
            out = replace(out, **{name: value})
        return out, problems


def _whole(text: str) -> int | None:
    """A budget value: a whole number, with optional '_' as in Python, 0 to 10**12."""
    digits = text.replace("_", "")
    if not digits.isascii() or not digits.isdigit() or len(digits) > 13:
        return None
    value = int(digits)
    return value if value <= 10**12 else None


DEFAULT_BUDGETS = Budgets()
