"""What ``labsim serve`` accepts on the wire, checked before a request costs anything.

Where it sits: the wire loop (``server``) reads a request's frames from the socket and asks
``refusal`` whether the bytes may be decoded at all; only then does cbor2 build Python
objects from them. The checks walk the CBOR bytes without building anything, so a hostile
message (an array header claiming 52 million items, ten million empty maps, a 50 MB text,
a nesting a thousand deep) is refused after reading at most ``MAX_ITEMS`` headers: cbor2
itself has no limits, and decoding such a message took gigabytes and minutes.

The limits (docs/coppeliasim.md, "Limits of labsim serve", gives the reasons):

* ``MAX_MESSAGE_BYTES``, 64 MiB: set on the socket as ZMQ_MAXMSGSIZE, so a larger message is
  dropped by ZeroMQ (it closes that peer's connection) before it is ever buffered whole. The
  largest legitimate request is far smaller: a 4K RGBA image (3840 x 2160 x 4 = 33,177,600
  bytes) fits twice over, and labsim's own largest (a world's mesh) is a few hundred kB.
* ``MAX_DEPTH``, 16: CoppeliaSim's Python client sends arguments nested two deep inside the
  request's map and its ``args`` list.
* ``MAX_ITEMS``, 1,000,000 data items in one message (a map entry counts its key and value).
* ``MAX_TEXT_BYTES``, 64 KiB for one text (a path, a name); byte strings (images) may use
  the whole message.
* No CBOR tags: the protocol never uses them, and some (value sharing, bignums, decimal
  fractions) build cyclic or enormous values.

``Deadline`` is the per-request time budget: loops whose length depends on what a client sent
call ``check()``; past the budget the request is answered with ``BudgetExceeded``'s text. The
budget is the CPU time of the thread answering the request (``time.thread_time``), not wall
time: on a machine under heavy load a legitimate request waits for a core without spending
its budget, while a request that makes the server compute for 5 s is still cut off.
"""
from __future__ import annotations

import contextvars
import time

MAX_MESSAGE_BYTES = 64 * 1024 * 1024
MAX_DEPTH = 16
MAX_ITEMS = 1_000_000
MAX_TEXT_BYTES = 64 * 1024
REQUEST_BUDGET_S = 5.0
_CHECK_EVERY = 4096  # items between deadline checks while scanning

_INDEFINITE = -1
_BREAK = 0xFF


class BudgetExceeded(Exception):
    """A request ran past its time budget; its text is the reply's ``err``."""


class Deadline:
    """The time budget of the request being answered, for loops that scale with its input."""

    _current: contextvars.ContextVar[float] = contextvars.ContextVar("labsim_serve_deadline", default=float("inf"))

    @classmethod
    def start(cls, budget_s: float) -> contextvars.Token[float]:
        return cls._current.set(time.thread_time() + budget_s)

    @classmethod
    def end(cls, token: contextvars.Token[float]) -> None:
        cls._current.reset(token)

    @classmethod
    def check(cls) -> None:
        """Raise ``BudgetExceeded`` once the current request's budget is spent."""
        if time.thread_time() > cls._current.get():
            raise BudgetExceeded("labsim serve: the request ran past its time budget and was abandoned "
                                 "(docs/coppeliasim.md, limits of labsim serve)")


class _Refused(Exception):
    pass


def refusal(raw: bytes) -> str | None:
    """Why ``raw`` may not be decoded (the reply's ``err`` text), or None when it may.

    Walks exactly one CBOR data item and wants nothing after it. Raises nothing but
    ``BudgetExceeded``, when the request's time budget runs out during the walk.
    """
    if len(raw) > MAX_MESSAGE_BYTES:
        return f"labsim serve: a request may be at most {MAX_MESSAGE_BYTES} bytes, this one has {len(raw)}"
    try:
        end = _Scanner(raw).item()
    except _Refused as e:
        return f"labsim serve: {e}"
    if end != len(raw):
        return "labsim serve: the request is not a CBOR message (bytes follow its first value)"
    return None


class _Scanner:
    """One pass over CBOR bytes with an explicit stack: counts, depth and lengths, no values."""

    def __init__(self, raw: bytes) -> None:
        self.raw = raw
        self.items = 0

    def _head(self, pos: int) -> tuple[int, int, int, int]:
        """(major type, additional info, argument, position after the head)."""
        raw = self.raw
        if pos >= len(raw):
            raise _Refused("the request is not a CBOR message (it ends inside a value)")
        byte = raw[pos]
        major, info = byte >> 5, byte & 0x1F
        pos += 1
        if info < 24:
            return major, info, info, pos
        if info in (24, 25, 26, 27):
            size = 1 << (info - 24)
            if pos + size > len(raw):
                raise _Refused("the request is not a CBOR message (it ends inside a value)")
            value = int.from_bytes(raw[pos:pos + size], "big")
            return major, info, value, pos + size
        if info == 31 and major in (2, 3, 4, 5, 7):
            return major, info, _INDEFINITE, pos
        raise _Refused("the request is not a CBOR message (a reserved header byte)")

    def item(self) -> int:
        """Walk the item at 0; return where it ends."""
        raw, pos = self.raw, 0
        stack: list[int] = []  # each open container: values still to read, or _INDEFINITE
        while True:
            if stack and stack[-1] == _INDEFINITE and pos < len(raw) and raw[pos] == _BREAK:
                stack.pop()
                pos += 1
            else:
                self._count()
                major, _, arg, pos = self._head(pos)
                pos, opened = self._one(major, arg, pos, len(stack))
                if opened is not None:
                    stack.append(opened)
                    continue
            # an item is complete: it completes the containers it filled
            while stack and stack[-1] != _INDEFINITE:
                stack[-1] -= 1
                if stack[-1] > 0:
                    break
                stack.pop()
            if not stack:
                return pos

    def _count(self) -> None:
        self.items += 1
        if self.items > MAX_ITEMS:
            raise _Refused(f"a request may hold at most {MAX_ITEMS} values")
        if self.items % _CHECK_EVERY == 0:
            Deadline.check()

    def _one(self, major: int, arg: int, pos: int, depth: int) -> tuple[int, int | None]:
        """One head: the next position, and the values a container opened here holds
        (None for anything else, and for an empty container, which is complete at once)."""
        left = len(self.raw) - pos
        if major in (0, 1):
            return pos, None
        if major in (2, 3):
            if arg == _INDEFINITE:
                return self._chunks(major, pos), None
            if arg > left:
                raise _Refused("the request is not a CBOR message (a string longer than the message)")
            if major == 3 and arg > MAX_TEXT_BYTES:
                raise _Refused(f"a text in a request may be at most {MAX_TEXT_BYTES} bytes, one has {arg}")
            return pos + arg, None
        if major in (4, 5):
            if depth + 1 > MAX_DEPTH:
                raise _Refused(f"a request may nest at most {MAX_DEPTH} arrays and maps deep")
            if arg == _INDEFINITE:
                return pos, _INDEFINITE
            count = arg if major == 4 else 2 * arg
            if count > MAX_ITEMS - self.items:
                raise _Refused(f"a request may hold at most {MAX_ITEMS} values")
            if count > left:  # each value takes at least a byte
                raise _Refused("the request is not a CBOR message (a container longer than the message)")
            return pos, count or None
        if major == 6:
            raise _Refused("CBOR tags are not part of CoppeliaSim's protocol")
        # major 7: simple values and floats; a break outside an indefinite container is malformed
        if arg == _INDEFINITE:
            raise _Refused("the request is not a CBOR message (a stray break)")
        return pos, None

    def _chunks(self, major: int, pos: int) -> int:
        """An indefinite-length string: definite chunks of the same type up to a break."""
        raw, total = self.raw, 0
        while True:
            if pos >= len(raw):
                raise _Refused("the request is not a CBOR message (it ends inside a value)")
            if raw[pos] == _BREAK:
                return pos + 1
            self._count()
            chunk_major, _, arg, pos = self._head(pos)
            if chunk_major != major or arg == _INDEFINITE or arg > len(raw) - pos:
                raise _Refused("the request is not a CBOR message (a malformed string chunk)")
            total += arg
            if major == 3 and total > MAX_TEXT_BYTES:
                raise _Refused(f"a text in a request may be at most {MAX_TEXT_BYTES} bytes")
            pos += arg


__all__ = ["MAX_DEPTH", "MAX_ITEMS", "MAX_MESSAGE_BYTES", "MAX_TEXT_BYTES", "REQUEST_BUDGET_S",
           "BudgetExceeded", "Deadline", "refusal"]
