"""What every answer of the stand-in shares: CoppeliaSim's error texts and a request's arguments.

A client's arguments arrive as CBOR decoded them (anything at all); the readers here take
numbers, handles, vectors and image crops as CoppeliaSim's own functions do, and fail with
CoppeliaSim's own words (``SimError``), which the server sends back as the call's error. Used
by ``labsim.runtime.serve.sim_api`` and the other tables of functions beside it.
"""
from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from labsim.runtime.serve.simulation import Client

Args = list[Any]  # a request's arguments, as CBOR decoded them: anything a client sent

E_PATH = "object does not exist, or alias/path is ill formatted."
E_HANDLE = "object does not exist."
E_ARGS = "one of the function's argument type is not correct."
E_FEW = "function requires more arguments."
E_POS_SIZE = "wrong position/size parameters."  # CoppeliaSim's SIM_ERROR_WRONG_POS_SIZE_PARAMS

class SimError(Exception):
    """An error a CoppeliaSim function would raise; becomes {"err": "<text> (in function ...)"}."""


class Wait:
    """What sim.step returns: reply ``_*wait*_`` and step on ``_*executed*_``."""


WAIT = Wait()
Handler = Callable[[Client, Args], list[object] | Wait]


# --- arguments ------------------------------------------------------------------------------------

SHOWN_CHARS = 100  # how much of a client's value an error quotes back


def shown(value: object) -> str:
    """A client's value as an error quotes it: a text up to SHOWN_CHARS, else its type. A
    reply must not grow with what a request sent (a million-item list, a 64 KiB path)."""
    if isinstance(value, str):
        return value if len(value) <= SHOWN_CHARS else value[:SHOWN_CHARS] + f"... ({len(value)} characters)"
    if value is None or isinstance(value, (bool, int, float)):
        return str(value)
    return f"a {type(value).__name__}"


def as_handle(value: object) -> int:
    """A handle from any number, as CoppeliaSim casts one (4.7 is 4); not a number: the type error."""
    if isinstance(value, float) and math.isfinite(value) and abs(value) < 2 ** 31:
        return int(value)
    if not isinstance(value, int) or isinstance(value, bool):
        raise SimError(E_ARGS)
    return value


def crop(pos: object, size: object, w: int, h: int) -> tuple[int, int, int, int]:
    """(x0, y0, sx, sy) of the part of a w x h vision sensor image a pos and size read, as
    getVisionSensorImg, getVisionSensorDepth and the older image calls all take them (a size
    of 0 reads to the edge): not two numbers, the type error; outside the image (inf and nan
    included), CoppeliaSim's "wrong position/size parameters"."""
    pos = pos if pos else [0, 0]
    size = size if size else [0, 0]
    if not (isinstance(pos, (list, tuple)) and isinstance(size, (list, tuple)) and len(pos) >= 2 and len(size) >= 2
            and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in (*pos[:2], *size[:2]))):
        raise SimError(E_ARGS)
    nums = (*pos[:2], *size[:2])
    if not all(math.isfinite(v) and abs(v) < 2 ** 31 for v in nums):
        raise SimError(E_POS_SIZE)
    x0, y0, sx, sy = (int(v) for v in nums)
    sx, sy = sx or w - x0, sy or h - y0
    if not (0 <= x0 < w and 0 <= y0 < h and 0 < sx <= w - x0 and 0 < sy <= h - y0):
        raise SimError(E_POS_SIZE)
    return x0, y0, sx, sy


def num(args: Args, i: int, default: float | None = None) -> float:
    if len(args) <= i or args[i] is None:
        if default is None:
            raise SimError(E_FEW)
        return default
    v = args[i]
    if not isinstance(v, (int, float)) or isinstance(v, bool) or not math.isfinite(v):
        raise SimError(E_ARGS)
    return float(v)


def integer(args: Args, i: int, default: int) -> int:
    if len(args) <= i or args[i] is None:
        return default
    return as_handle(args[i])


def vec(args: Args, i: int, n: int) -> list[float]:
    if len(args) <= i:
        raise SimError(E_FEW)
    v = args[i]
    if not isinstance(v, (list, tuple)) or len(v) < n or not all(
            isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) for x in v[:n]):
        raise SimError(E_ARGS)
    return [float(x) for x in v[:n]]
