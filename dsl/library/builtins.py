"""The built-in functions, actions and names of the language, with their types.

The checker reads signatures from here; the generated code calls the implementations (bound
by ``labsim.dsl.library.support``). A function that can fail on some inputs (``sqrt(-1)``, ``log(0)``)
raises, and the guarded call turns that into the documented result (docs/language.md,
"Runtime faults") and a warning.
"""
from __future__ import annotations

import functools
import math
import operator
import random
from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum

from labsim.foundation.numbers import WHOLE_LIMIT


class Type(Enum):
    NUMBER = "number"
    BOOL = "boolean"
    STATE = "state"
    IMAGE = "image"
    CENTROID = "centroid"  # a record: .x, .y (pixels), .found
    JOINT = "joint"  # .position (m or rad), .velocity (m/s or rad/s)
    FORCE = "force sensor"  # .force (N)
    BODY = "body"  # .x, .z (m, in the mechanism's plane), .angle (rad)
    NUMBERS = "group of numbers"  # [sonar4, sonar5], sonar1..sonar8 (version 1.2)
    BOOLS = "group of booleans"  # front < 0.5 with front a group of numbers
    TEXT = "text"  # "left": what a log's field may show
    LIST = "list of rows"  # a list parameter of rows, [[0, -1], [3, -1]]: waypoints[i] is a row (version 1.3)

    def __str__(self) -> str:
        return self.value

    @property
    def a(self) -> str:
        """The type with its article, for messages: 'a number', 'an image', 'text'."""
        if self is Type.TEXT:
            return "text"
        return ("an " if self.value[0] in "aeiou" else "a ") + self.value

    @property
    def member(self) -> Type:
        """A group's members' type; a number or boolean is its own."""
        return {Type.NUMBERS: Type.NUMBER, Type.BOOLS: Type.BOOL}.get(self, self)

    @property
    def grouped(self) -> Type:
        """The group of this type: numbers of a number; a group is its own."""
        return {Type.NUMBER: Type.NUMBERS, Type.BOOL: Type.BOOLS}.get(self, self)


N, B, I = Type.NUMBER, Type.BOOL, Type.IMAGE  # noqa: E741 (one letter keeps the signature table readable)

# The fields of record types, and what generated code indexes for each.
FIELDS: dict[Type, dict[str, tuple[int, Type]]] = {
    Type.CENTROID: {"x": (0, N), "y": (1, N), "found": (2, B)},
    Type.JOINT: {"position": (0, N), "velocity": (1, N)},
    Type.FORCE: {"force": (0, N)},
    Type.BODY: {"x": (0, N), "z": (1, N), "angle": (2, N)},
}


@dataclass(frozen=True)
class Function:
    name: str
    params: tuple[Type, ...]
    returns: Type
    impl: Callable[..., object] | str  # a callable, or "module:name" imported when first compiled
    doc: str
    variadic: bool = False  # the last parameter repeats; at least len(params) arguments
    uses_rng: bool = False  # impl takes the robot's random.Random as its first argument
    optional: int = 0  # how many of the last params may be left out
    stateful: bool = False  # keeps state per robot and call site: meaningful only if run every tick
    # what each argument is, for messages (pid() takes 4 or 5 arguments (error, kp, ...)); none
    # where the arguments all mean one kind of thing (abs(x), min(a, b, ...))
    names: tuple[str, ...] = ()

    def resolve(self) -> Callable[..., object]:
        if isinstance(self.impl, str):
            import importlib

            module, name = self.impl.split(":")
            return getattr(importlib.import_module(module), name)
        return self.impl


def _randint(rng: random.Random, a: float, b: float) -> float:
    if not (abs(a) <= WHOLE_LIMIT and abs(b) <= WHOLE_LIMIT):  # nan too; the checker refuses such literals
        raise ValueError(f"randint({a:g}, {b:g}) has a bound beyond {WHOLE_LIMIT:g} (2**53)")
    lo, hi = math.ceil(a), math.floor(b)
    if lo > hi:
        raise ValueError(f"randint({a:g}, {b:g}) has no integer between its bounds")
    return float(rng.randint(lo, hi))  # a float, as every number of the language (docs/language.md)


def _sign(x: float) -> float:
    return float((x > 0) - (x < 0)) if x == x else math.nan  # a float, as every number (-sign(0) is -0.0)


def _clamp(x: float, lo: float, hi: float) -> float:
    return lo if x < lo else hi if x > hi else x


def _min(a: float, b: float, *rest: float) -> float:
    """Smallest value; nan if any argument is nan (Python's min would depend on the order)."""
    if rest and _no_nan(a + b + sum(rest)):  # a lidar's 360 beams: C's loop, the same first of equals
        m = b if b < a else a
        r = min(rest)
        return r if r < m else m
    if a != a or b != b:
        return math.nan
    m = b if b < a else a
    for x in rest:
        if x != x:
            return math.nan
        if x < m:
            m = x
    return m


def _max(a: float, b: float, *rest: float) -> float:
    """Largest value; nan if any argument is nan."""
    if rest and _no_nan(a + b + sum(rest)):
        m = b if b > a else a
        r = max(rest)
        return r if r > m else m
    if a != a or b != b:
        return math.nan
    m = b if b > a else a
    for x in rest:
        if x != x:
            return math.nan
        if x > m:
            m = x
    return m


def _no_nan(total: float) -> bool:
    """Whether a sum of values shows that none of them is nan: a nan makes the sum nan, and
    so does inf beside -inf, which is then only a slower path, never a wrong answer. Summing
    in C and taking C's min is several times cheaper than a Python loop over a lidar's beams,
    and gives the same member (both keep the first of equals)."""
    return total == total


def _floor(x: float) -> float:
    return x if x in (math.inf, -math.inf) else float(math.floor(x))  # an infinity is whole; nan raises


def _ceil(x: float) -> float:
    return x if x in (math.inf, -math.inf) else float(math.ceil(x))


def _round(x: float) -> float:
    return x if x in (math.inf, -math.inf) else float(round(x))


def _log(x: float) -> float:
    if x == 0:
        return -math.inf
    return math.log(x)


FUNCTIONS: dict[str, Function] = {f.name: f for f in (
    Function("abs", (N,), N, abs, "absolute value"),
    Function("min", (N, N), N, _min, "smallest of two or more values", variadic=True),
    Function("max", (N, N), N, _max, "largest of two or more values", variadic=True),
    Function("clamp", (N, N, N), N, _clamp, "clamp(x, lo, hi): x limited to [lo, hi]", names=("x", "lo", "hi")),
    Function("sqrt", (N,), N, math.sqrt, "square root"),
    Function("hypot", (N, N), N, math.hypot, "hypot(x, y): length of the vector (x, y)", names=("x", "y")),
    Function("sin", (N,), N, math.sin, "sine of an angle in radians"),
    Function("cos", (N,), N, math.cos, "cosine of an angle in radians"),
    Function("tan", (N,), N, math.tan, "tangent of an angle in radians"),
    Function("atan2", (N, N), N, math.atan2, "atan2(y, x): angle of (x, y) in radians", names=("y", "x")),
    Function("exp", (N,), N, math.exp, "e to the power x"),
    Function("log", (N,), N, _log, "natural logarithm"),
    Function("floor", (N,), N, _floor, "largest integer <= x"),
    Function("ceil", (N,), N, _ceil, "smallest integer >= x"),
    Function("round", (N,), N, _round, "nearest integer (halves to even)"),
    Function("sign", (N,), N, _sign, "-1, 0 or 1"),
    Function("deg", (N,), N, math.degrees, "radians to degrees"),
    Function("rad", (N,), N, math.radians, "degrees to radians"),
    Function("randint", (N, N), N, _randint, "randint(a, b): a random integer n, a <= n <= b",
             uses_rng=True, names=("a", "b")),
    Function("random", (), N, random.Random.random, "a random number in [0, 1)", uses_rng=True),
    Function("uniform", (N, N), N, random.Random.uniform, "uniform(a, b): a random number in [a, b]",
             uses_rng=True, names=("a", "b")),
    Function("gauss", (N, N), N, random.Random.gauss, "gauss(mean, sd): a normally distributed number",
             uses_rng=True, names=("mean", "sd")),
    # images (labsim.dsl.library.images; OpenCV is imported only when a behaviour uses them)
    Function("gray", (I,), I, "labsim.dsl.library.images:gray", "RGB to gray"),
    Function("threshold", (I, N), I, "labsim.dsl.library.images:threshold",
             "threshold(img, level): 255 where the gray pixel is > level, else 0 (OpenCV THRESH_BINARY)",
             names=("img", "level")),
    Function("invert", (I,), I, "labsim.dsl.library.images:invert", "255 - each pixel"),
    Function("crop", (I, N, N, N, N), I, "labsim.dsl.library.images:crop",
             "crop(img, x, y, w, h): the rectangle with top-left pixel (x, y)",
             names=("img", "x", "y", "w", "h")),
    Function("mean", (I,), N, "labsim.dsl.library.images:mean", "mean pixel value, 0..255"),
    Function("area", (I,), N, "labsim.dsl.library.images:area", "number of set (non-zero) pixels"),
    Function("width", (I,), N, "labsim.dsl.library.images:width", "image width in pixels"),
    Function("height", (I,), N, "labsim.dsl.library.images:height", "image height in pixels"),
    Function("centroid", (I,), Type.CENTROID, "labsim.dsl.library.images:centroid",
             "centroid(img): .x, .y of the set pixels (from the left and the top), .found"),
    # controllers
    Function("pid", (N, N, N, N, N), N, "labsim.dsl.library.support:make_pid",
             "pid(error, kp, ki, kd[, limit]): a PID controller with its own state per robot and call site; "
             "a tick with an inf or nan error repeats the last finite output and leaves the state alone",
             optional=1, stateful=True, names=("error", "kp", "ki", "kd", "limit")),
    # time and memory (labsim.dsl.library.memory): each call site keeps its own state per robot
    Function("prev", (N, N), N, "labsim.dsl.library.memory:prev",
             "prev(x, initial): x on the previous tick (initial on the first); x may be a boolean", stateful=True,
             names=("x", "initial")),
    Function("rising", (B,), B, "labsim.dsl.library.memory:rising",
             "rising(c): true on a tick where c holds and did not on the previous tick "
             "(format 1.2: never on the first tick)", stateful=True),
    Function("falling", (B,), B, "labsim.dsl.library.memory:falling",
             "falling(c): true on a tick where c does not hold and did on the previous tick", stateful=True),
    Function("hold", (B, B), B, "labsim.dsl.library.memory:hold",
             "hold(set, reset): a latch, true from a tick where set holds until one where reset holds",
             stateful=True, names=("set", "reset")),
    Function("rate", (N,), N, "labsim.dsl.library.memory:rate",
             "rate(x): x's change per second since the previous tick (0 on the first, and for an inf or nan x)",
             stateful=True),
    Function("held", (B,), N, "labsim.dsl.library.memory:held",
             "held(c): seconds c has held without a break (0 while it does not)", stateful=True),
    Function("remember", (N, B, N), N, "labsim.dsl.library.memory:remember",
             "remember(x, when[, initial]): x at the last tick when 'when' held (initial, or nan, before)",
             optional=1, stateful=True, names=("x", "when", "initial")),
    # accumulators (version 1.2)
    Function("counter", (B, B), N, "labsim.dsl.library.memory:counter",
             "counter(c[, reset]): how many times c became true (the ticks rising(c) holds); 0 while reset holds",
             optional=1, stateful=True, names=("c", "reset")),
    Function("total", (N, B), N, "labsim.dsl.library.memory:total",
             "total(x[, reset]): the sum of x over the ticks (inf and nan left out); 0 while reset holds",
             optional=1, stateful=True, names=("x", "reset")),
)}

@dataclass(frozen=True)
class Reduction:
    """A function of a whole group, written as a call with the group as its one argument."""

    name: str
    takes: Type  # Type.NUMBERS or Type.BOOLS
    returns: Type
    doc: str


# Reductions of a group (version 1.2). min, max and mean are also functions of numbers (or of an
# image); the checker tells them apart by their argument's type.
REDUCTIONS: dict[str, Reduction] = {r.name: r for r in (
    Reduction("min", Type.NUMBERS, N, "the smallest member; nan if one is nan"),
    Reduction("max", Type.NUMBERS, N, "the largest member; nan if one is nan"),
    Reduction("sum", Type.NUMBERS, N, "the members added up"),
    Reduction("mean", Type.NUMBERS, N, "the members' mean"),
    Reduction("argmin", Type.NUMBERS, N, "where the smallest member is, counted from 0 (the first of equals)"),
    Reduction("argmax", Type.NUMBERS, N, "where the largest member is, counted from 0 (the first of equals)"),
    Reduction("any", Type.BOOLS, B, "true if a member is true"),
    Reduction("all", Type.BOOLS, B, "true if every member is true"),
    Reduction("count", Type.BOOLS, N, "how many members are true"),
)}


def argmin(*values: float) -> float:
    """Where the smallest value is, from 0, the first of equals; nan values are passed over (nan if all are)."""
    return argmin_of(values)


def argmax(*values: float) -> float:
    """Where the largest value is, from 0, the first of equals; nan values are passed over (nan if all are)."""
    return argmax_of(values)


# The reductions of a group that is a run of the tick's channel values, called on that list
# (or a slice of it) rather than on one argument per member: a 360-beam scan is then never
# unpacked into locals nor passed as 360 arguments (docs/decisions.md §25). Each
# gives what the member-by-member form gives, bit for bit (tests/unit/test_group_sequences.py).
Values = list[float] | tuple[float, ...]


def argmin_of(values: Values) -> float:
    """``argmin`` of a sequence of two or more values."""
    if values and _no_nan(sum(values)):  # C's min and index: the first member equal to the smallest
        return float(values.index(min(values)))
    best, at = math.inf, math.nan
    for k, v in enumerate(values):
        if v < best or (v == best and at != at):
            best, at = v, float(k)
    return at


def argmax_of(values: Values) -> float:
    """``argmax`` of a sequence of two or more values."""
    if values and _no_nan(sum(values)):
        return float(values.index(max(values)))
    best, at = -math.inf, math.nan
    for k, v in enumerate(values):
        if v > best or (v == best and at != at):
            best, at = v, float(k)
    return at


def argmin_at(values: Values, least: float) -> float:
    """``argmin`` of a sequence whose ``min_of`` is ``least``, computed this tick: where the
    first member equal to it is, as ``argmin_of`` finds it; a nan minimum means a member is
    nan, and argmin passes nans over, so then the whole search."""
    return float(values.index(least)) if least == least else argmin_of(values)


def argmax_at(values: Values, most: float) -> float:
    """``argmax`` of a sequence whose ``max_of`` is ``most``, computed this tick."""
    return float(values.index(most)) if most == most else argmax_of(values)


def min_of(values: Values) -> float:
    """``_min(*values)`` of a sequence of two or more values: C's ``min`` keeps the first of
    equals as ``_min`` does (-0.0 before 0.0 when it comes first); nan if a value is nan."""
    if _no_nan(sum(values)):
        return min(values)
    for x in values:
        if x != x:
            return math.nan
    return min(values)  # no nan after all: inf beside -inf made the sum nan


def max_of(values: Values) -> float:
    """``_max(*values)`` of a sequence of two or more values."""
    if _no_nan(sum(values)):
        return max(values)
    for x in values:
        if x != x:
            return math.nan
    return max(values)


def sum_of(values: Values) -> float:
    """The members added left to right from the first, as ``(a + b + c)`` adds them (Python's
    ``sum`` starts from 0, which turns a first -0.0 into 0.0, and from 3.12 compensates its
    rounding)."""
    return functools.reduce(operator.add, values)


SEQUENCE_FUNCTIONS: dict[str, Callable[..., float]] = {
    "min_of": min_of, "max_of": max_of, "argmin_of": argmin_of, "argmax_of": argmax_of, "sum_of": sum_of,
    "argmin_at": argmin_at, "argmax_at": argmax_at}


# Names added after version 1: a version 1 file may have used them for its own parameters,
# signals, states or sliders, which then hide them (calls are told apart by their parentheses).
SHADOWABLE = frozenset({"prev", "rising", "falling", "hold", "rate", "held", "remember",
                        "state_time", "entered", "index",
                        "counter", "total", "sum", "argmin", "argmax", "any", "all",
                        "start_x", "start_y", "start_heading", "len"})

# Functions whose result depends on earlier ticks: each call site keeps state per robot.
STATEFUL = frozenset(f.name for f in FUNCTIONS.values() if f.stateful)

# detected(sonar5) takes a distance sensor's *name*, not its value.
DETECTED = "detected"


@dataclass(frozen=True)
class ActionSpec:
    name: str
    params: tuple[str, ...]  # parameter names, all numbers
    doc: str


ACTIONS: dict[str, ActionSpec] = {a.name: a for a in (
    ActionSpec("arc", ("left", "right"), "wheel target velocities in rad/s (left, right)"),
    ActionSpec("wheels", ("left", "right"), "the same as arc: wheel target velocities in rad/s"),
    ActionSpec("move", ("speed",), "both wheels at the same velocity, rad/s"),
    ActionSpec("drive", ("v", "w"), "forward speed v in m/s and turn rate w in rad/s (counter-clockwise)"),
    ActionSpec("stop", (), "both wheels at 0"),
    ActionSpec("set_velocity", ("joint", "velocity"), "a joint's target velocity, m/s or rad/s"),
    ActionSpec("set_position", ("joint", "position"), "a joint's target position, m or rad"),
    ActionSpec("log", ("text",), 'log("text {expr:.2f}"): print a line with the time and robot, and trace it'),
)}

# Actions students reach for to print text, from other languages: each is told to use log("...").
PRINTS = frozenset({"print", "say", "echo", "write", "display", "show", "printf", "println", "puts"})

# Actions whose first argument names a joint rather than giving a value.
JOINT_ACTIONS = {"set_velocity": "velocity", "set_position": "position"}


class Aggregate(Enum):
    """How a metric folds a per-tick value over the run."""

    COUNT = "count"  # rising edges of a condition
    DURATION = "duration"  # seconds a condition held
    MEAN = "mean"
    MAXIMUM = "maximum"
    MINIMUM = "minimum"
    RMS = "rms"  # root mean square
    FINAL = "final"  # value at the last tick

    @property
    def argument(self) -> Type:
        return B if self in (Aggregate.COUNT, Aggregate.DURATION) else N

    @property
    def better(self) -> Better | None:
        """Which way is better when the metric does not say: fewer events, smaller errors and
        peaks; a higher floor (``minimum``, the closest a robot came) and a higher end value. A
        duration is time in a good state as often as in a bad one, so it has no default."""
        if self is Aggregate.DURATION:
            return None
        return Better.HIGHER if self in (Aggregate.MINIMUM, Aggregate.FINAL) else Better.LOWER


class Better(Enum):
    """Which way a metric is better (``better:`` in a metric; a sweep marks the best setting by it)."""

    HIGHER = "higher"
    LOWER = "lower"


AGGREGATES: dict[str, Aggregate] = {a.value: a for a in Aggregate}

# Names every expression may use besides sensors, params and lets.
CONSTANTS: dict[str, float] = {"pi": math.pi, "inf": math.inf}
VARIABLES: dict[str, Type] = {"time": N, "tick": N, "dt": N, "state": Type.STATE,
                              "state_time": N, "entered": B, "index": N}
# Variables computed per tick only by behaviours that read them (codegen gives them slots).
STATE_CLOCK = ("state_time", "entered")
# Format 1.3: a robot's own commands read back, and where it started (per-robot slots, only when read):
# last tick's wheel commands as sent (rad/s, clamped to the model's limit), the start pose (m, m, rad)
WHEELS = ("wheel_left", "wheel_right")
READ_BACK: dict[str, Type] = {"wheel_left": N, "wheel_right": N, "start_x": N, "start_y": N, "start_heading": N}

# Names the trace uses for its own columns: no signal may take them.
TRACE_COLUMNS = frozenset({"tick", "time", "robot", "x", "y", "heading", "collided", "state", "rule",
                           "events", "wheel_left", "wheel_right"})

KEYWORDS = frozenset({"if", "then", "else", "always", "and", "or", "not", "goto", "true", "false"})


# Functions students reach for under another name: what to write instead.
MEANT = {
    "distance": "hypot(dx, dy)", "dist": "hypot(dx, dy)",
    "norm": "hypot(dx, dy)", "sqr": "x ** 2", "pow": "x ** y", "power": "x ** y",
    "average": "mean(...)", "avg": "mean(...)", "atan": "atan2(y, x)", "arctan": "atan2(y, x)",
    "absolute": "abs(x)", "limit": "clamp(x, lo, hi)", "constrain": "clamp(x, lo, hi)",
    "print": 'the action log("...")', "delay": "state_time or held(...)", "wait": "state_time or held(...)",
    "previous": "prev(x, initial)", "integral": "total(x * dt)", "integrate": "total(x * dt)",
    "accumulate": "total(x)", "edges": "counter(c)", "tally": "counter(c)",
}
