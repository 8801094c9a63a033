"""What generated code calls while a behaviour runs: the last stage of the language, at run time.

``labsim.dsl.emit.codegen`` writes Python that reads and writes a robot's ``Slots`` (laid out as
``TIME``, ``TICK``, ``STATE``, then from ``FIRST_CHANNEL`` the channels, signals and sliders),
calls the built-ins through the names ``namespace`` binds, and sends every operation that can
fault through a ``guard`` bound to its ``FaultSite``. ``labsim.dsl.emit.program`` binds all of it to
one robot; the runtime reads the metric accumulators back with ``metric_result``.

Runtime faults have defined results (IEEE 754 where it has one): ``x / 0`` is ±inf (0/0 and
nan/0 are nan), ``x % 0`` nan, ``sqrt(-1)`` nan, ``log(0)`` -inf, an overflowing power ±inf; a
``pid()`` given inf or nan keeps its state and repeats its last finite output. Each produces a
warning naming the site and the tick, through ``Faults``: the first at each site at once, the
rest counted for the summary.
"""
from __future__ import annotations

import math
import random
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from labsim.backends.scene.models import RobotModel
from labsim.dsl.library.builtins import FUNCTIONS, SEQUENCE_FUNCTIONS, Aggregate, Type, argmax, argmin
from labsim.dsl.library.memory import PRIMED
from labsim.foundation.diagnostics import Diagnostic
from labsim.foundation.numbers import place_text

if TYPE_CHECKING:  # images are NumPy arrays; numpy is imported when an image function is
    import numpy as np

INF = math.inf

# Fixed slots at the start of every robot's slot list; channels and signals follow.
TIME, TICK, STATE = 0, 1, 2
FIRST_CHANNEL = 3


class Slots(list):
    """One robot's values for the current tick: time, tick, state, channels, then signals."""


@dataclass(frozen=True)
class FaultSite:
    where: str  # "rule wander:2", "signal 'r'", ...
    diagnostic: Diagnostic  # points at the faulting expression


class Faults:
    """Collects runtime faults; the first at each site is reported at once, the rest counted."""

    def __init__(self, emit: Callable[[str], None] | None = None, clock: Callable[[], int] | None = None):
        self.emit = emit
        # the tick a fault happens on; the run sets it (slots hold the tick only in fleets)
        self.clock = clock
        self.counts: dict[tuple[FaultSite, str], int] = {}
        self.first: dict[tuple[FaultSite, str], tuple[int, str]] = {}
        self.by_robot: dict[str, int] = {}  # robot -> its faults, every site together

    def report(self, site: FaultSite, what: str, tick: int, robot: str, counted: str | None = None) -> None:
        """A fault at a site: ``what`` is its warning; ``counted``, when given, the words its site's
        faults of this kind are counted under (one warning and one summary line however many values
        ``what`` names: a missing member's place differs tick by tick)."""
        if self.clock is not None:
            tick = self.clock()
        key = (site, what if counted is None else counted)
        self.by_robot[robot] = self.by_robot.get(robot, 0) + 1
        n = self.counts.get(key, 0)
        self.counts[key] = n + 1
        if n == 0:
            self.first[key] = (tick, robot)
            if self.emit is not None:
                self.emit(self.describe(site, what, tick, robot))

    def summary(self) -> list[str]:
        """One line per site and fault, for the run's summary; a rule or signal with the same fault
        at several places names each by its line, column and expression, so that no two read alike."""
        out = []
        shared = Counter((site.where, what) for site, what in self.counts)
        for (site, what), n in self.counts.items():
            tick, robot = self.first[(site, what)]
            out.append(f"{_fault_place(site) if shared[site.where, what] > 1 else site.where}: {what}: {n} "
                       f"time{'s' if n != 1 else ''} (first at tick {tick}, robot {robot})")
        return out

    @staticmethod
    def describe(site: FaultSite, what: str, tick: int, robot: str) -> str:
        d = site.diagnostic
        head = Diagnostic(d.path, f"{what} in {site.where}, robot {robot}, tick {tick}", d.line, d.col,
                          d.end_col, "warning", d.source_line,
                          ("the run goes on with the result above; later occurrences are counted in the summary",))
        return head.format()


def _fault_place(site: FaultSite) -> str:
    """``rule main:2 at 20:49 (0/0)``: a site by its place in the file and its expression (a long one cut)."""
    d = site.diagnostic
    written = d.source_line[d.col - 1:d.end_col - 1] if d.col and d.end_col else ""
    written = written if len(written) <= 40 else written[:30] + "..."
    return f"{site.where} at {d.line}:{d.col}" + (f" ({written})" if written else "")


# -- metric accumulators: what decide() folds each tick (codegen's METRIC_CODE) ----------------
def initial_accumulator(aggregate: Aggregate) -> list:
    """A metric's accumulator before the first tick."""
    if aggregate is Aggregate.COUNT:
        return [0, False]  # rising edges so far, the condition at the previous tick
    if aggregate is Aggregate.DURATION:
        return [0]  # ticks the condition held; times dt at the end
    if aggregate in (Aggregate.MEAN, Aggregate.RMS):
        return [0.0, 0]  # sum (of squares) and count of finite values
    if aggregate is Aggregate.MAXIMUM:
        return [-INF]
    if aggregate is Aggregate.MINIMUM:
        return [INF]
    return [math.nan]


def metric_result(aggregate: Aggregate, acc: list[float], dt_s: float) -> float:
    """The value of a metric from its accumulator (see initial_accumulator)."""
    if aggregate is Aggregate.COUNT:
        return acc[0]
    if aggregate is Aggregate.DURATION:
        return acc[0] * dt_s
    if aggregate is Aggregate.MEAN:
        return acc[0] / acc[1] if acc[1] else math.nan
    if aggregate is Aggregate.RMS:
        return math.sqrt(acc[0] / acc[1]) if acc[1] else math.nan
    if aggregate in (Aggregate.MAXIMUM, Aggregate.MINIMUM) and acc[0] in (INF, -INF):
        return math.nan  # no finite value all run
    return acc[0]


# -- what generated code may call ---------------------------------------------------------------
def namespace(rng: random.Random, model: RobotModel | None, functions: tuple[str, ...]) -> dict[str, object]:
    """What generated code may use: the functions it calls, the robot's generator and model."""
    randint = rng.randint
    ns: dict[str, object] = {"_inf": INF, "_nan": math.nan, "_randint": lambda a, b: float(randint(a, b)),
                             "_random": rng.random, "_uniform": rng.uniform, "_gauss": rng.gauss,
                             "_argmin": argmin, "_argmax": argmax}
    for name in functions:
        ns["_" + name] = SEQUENCE_FUNCTIONS[name] if name in SEQUENCE_FUNCTIONS else FUNCTIONS[name].resolve()
    # drive(v, w) turns m/s and rad/s into wheel rad/s with the robot's own geometry
    ns["_radius"] = model.wheel_radius_m if model else 1.0
    ns["_half_axle"] = model.axle_length_m / 2 if model else 0.5
    ns["_limit"] = model.max_wheel_speed_rad_s if model else INF  # wheel_left/wheel_right read back as sent
    return ns


PID_NOT_FINITE = ("pid() of an inf or nan error or gain (the result is its last finite output; its state does "
                  "not change)")
PID_OVERFLOW = "pid(): overflow (the result is its last finite output; its state does not change)"


def make_pid(report: Callable[[str], None]) -> Callable[..., float]:
    """One call site's controller (docs/language.md, "PID"), the lab's discrete PID: integral +=
    error, derivative = error - previous error. With ``limit`` the output is clamped to
    [-limit, limit], and the integral does not grow while the output is saturated in the
    direction the error pushes (clamping anti-windup). A tick with an inf or nan error or gain,
    or one that overflows, changes nothing and gives the last finite output (0 before any), with
    a warning through ``report``."""
    state = [0.0, 0.0, 0.0]  # this robot's integral, previous error and last finite output at this site

    def pid(e: float, kp: float, ki: float, kd: float, limit: float | None = None) -> float:
        if e * 0.0 + kp * 0.0 + ki * 0.0 + kd * 0.0 != 0.0:  # one of them is inf or nan
            report(PID_NOT_FINITE)
            return state[2]
        integral = state[0] + e
        out = kp * e + ki * integral + kd * (e - state[1])
        if limit is not None and abs(out) > limit:
            if (out > 0) == (e > 0):
                integral = state[0]  # do not wind up further
                out = kp * e + ki * integral + kd * (e - state[1])
            out = -limit if out < -limit else limit if out > limit else out
        if out * 0.0 + integral * 0.0 != 0.0:  # an overflow: the state stays as it was
            report(PID_OVERFLOW)
            return state[2]
        state[0] = integral
        state[1] = e
        state[2] = out
        return out
    return pid


def show_field(value: object, spec: str) -> str:
    """A label's or a log's field: ``format`` with the field's spec, or plain when it does not apply.

    Slots hold floats: ``{arm:d}`` of 5.0 shows 5, and of a fraction (``{time:d}`` at 0.15 s) the
    number as ``{x:g}`` shows it, 0.15, not the float's every digit (0.15000000000000002)."""
    if spec.endswith("d") and isinstance(value, float) and value.is_integer():
        value = int(value)
    try:
        return format(value, spec)
    except (ValueError, TypeError):
        return format(value, "g") if isinstance(value, float) else str(value)


def site_kind(name: str, version: float) -> str:
    """The guard kind of a call site of the stateful function ``name`` in a file of format ``version``:
    ``rising@1.2`` where the function's first tick means something else from 1.2 on."""
    return f"{name}@1.2" if name in PRIMED and version >= 1.2 else name


def guard(kind: str, site: FaultSite, faults: Faults, slots: Slots, robot: str,
          rng: random.Random, dt_s: float = 0.05) -> Callable[..., object]:
    """A fault-checked (or stateful) operation for one site of generated code.

    A stateful function's kind may carry the format version whose meaning it has
    (``rising@1.2``: labsim.dsl.library.memory.PRIMED).
    """

    def report(what: str, counted: str | None = None) -> None:
        faults.report(site, what, int(slots[TICK]), robot, counted)

    if kind in _ARITHMETIC:
        return _ARITHMETIC[kind](report)
    if kind in ("[]", "[]?"):
        return _pick(report, math.nan if kind == "[]" else False)
    if kind == "[row]":
        clock = faults.clock
        return _pick_row(report, clock if clock is not None else (lambda: int(slots[TICK])))
    if kind == "pid":
        return make_pid(report)
    if kind == "say":
        def say(value: float) -> float:  # a value that is not finite is not sent (labsim.runtime.radio)
            if value - value == 0.0:
                return value
            report(f"say() of {value}: not sent (only finite numbers are)", "say() of a value that is not finite: "
                   "not sent")
            return math.nan
        return say
    if kind == "say range":
        def reach(value: float) -> float:  # no one is within a range that is not more than 0 (labsim.runtime.radio)
            if not value > 0.0:
                report(f"say()'s range of {value:g} m: heard by no one (a range is more than 0 metres)",
                       "say()'s range not more than 0: heard by no one")
            return value
        return reach
    name, _, since = kind.partition("@")
    if name in FUNCTIONS and FUNCTIONS[name].stateful:
        factory: Callable[..., Callable[..., object]] = FUNCTIONS[name].resolve()  # type: ignore[assignment]
        return factory(dt_s, report, primed=True) if since else factory(dt_s, report)  # labsim.dsl.library.memory
    if kind == "centroid":
        from labsim.dsl.library.images import EmptyCentroid, centroid

        def centroid_of(img: np.ndarray) -> tuple[float, float, bool]:
            try:
                return centroid(img)
            except EmptyCentroid as empty:
                report("centroid of an image with no set pixel (the result is the image centre, .found false)")
                return empty.result
        return centroid_of
    return _guarded_call(kind, report, rng)


def _divide(report: Callable[[str], None]) -> Callable[[float, float], float]:
    def divide(x: float, y: float) -> float:
        try:
            return x / y
        except ZeroDivisionError:
            report("division by zero")
            return math.copysign(INF, x) if x and x == x else math.nan  # 0 / 0 and nan / 0 are nan
    return divide


def _modulo(report: Callable[[str], None]) -> Callable[[float, float], float]:
    def modulo(x: float, y: float) -> float:
        try:
            return x % y
        except ZeroDivisionError:
            report("modulo by zero")
            return math.nan
    return modulo


def _power(report: Callable[[str], None]) -> Callable[[float, float], float]:
    def power(x: float, y: float) -> float:
        # before Python's **, which makes such a power complex, or overflows on a huge complex one
        if -INF < x < 0 and -INF < y < INF and not float(y).is_integer():
            report("a negative number to a fractional power")
            return math.nan
        try:
            return float(x) ** y  # floats: an int power would grow without bound
        except ZeroDivisionError:
            report("zero to a negative power")
            return INF
        except OverflowError:
            report("overflow in '**'")
            return -INF if x < 0 and y % 2 == 1 else INF  # a negative number to an odd power is negative
    return power


_ARITHMETIC: dict[str, Callable[[Callable[[str], None]], Callable[[float, float], float]]] = {
    "/": _divide, "%": _modulo, "**": _power}


def _pick(report: Callable[[str, str], None], missing: object) -> Callable[[tuple, float], object]:
    """``front[k]`` with k known only at run time: the member at place k, or ``missing`` (nan, or
    false for booleans) and a warning when there is none: the first place missed is named, the
    others counted with it."""
    def pick(members: tuple, k: float) -> object:
        if 0 <= k < len(members) and k == int(k):
            return members[int(k)]
        n = len(members)
        report(f"no member at place {place_text(k)} of a group of {n} (places count from 0)",
               f"no member at the place asked of a group of {n} (places count from 0)")
        return missing
    return pick


def _pick_row(report: Callable[[str, str], None], tick_now: Callable[[], int]) -> Callable[[tuple, float], float]:
    """``waypoints[k]`` with k known only at run time (format 1.3): one column's value at row k, or nan and
    a warning when there is no row k; each of a row's columns is picked through the same guard, which
    warns once a tick."""
    warned = [-1]

    def pick(column: tuple, k: float) -> float:
        if 0 <= k < len(column) and k == int(k):
            return column[int(k)]
        tick = tick_now()  # the run's clock: a single robot's slots do not hold the tick
        if warned[0] != tick:
            warned[0] = tick
            n = len(column)
            report(f"no row at place {place_text(k)} of a list of {n} rows (places count from 0)",
                   f"no row at the place asked of a list of {n} rows (places count from 0)")
        return math.nan
    return pick


def _guarded_call(kind: str, report: Callable[[str], None], rng: random.Random) -> Callable[..., object]:
    """A built-in that may raise, turned into its documented result and a warning."""
    f = FUNCTIONS[kind]
    impl = f.resolve()
    if f.uses_rng:
        impl = impl.__get__(rng) if kind != "randint" else (lambda a, b, _f=impl: _f(rng, a, b))
    fallback: object = math.nan
    if f.returns is Type.IMAGE:
        from labsim.dsl.library.images import EMPTY
        fallback = EMPTY

    def call(*args: float) -> object:
        try:
            return impl(*args)
        except OverflowError:  # exp(1000): the number is too large
            report(f"{kind}(): overflow")
            return INF if f.returns is Type.NUMBER else fallback
        except (ValueError, ZeroDivisionError) as exc:
            report(f"{kind}(): {exc}" if str(exc) else f"{kind}() failed")
            return fallback
    return call
