"""Range analysis: the interval an expression's value stays in, for the linter's warnings.

``labsim.dsl.analysis.lint`` hands this module each comparison and each call of a checked behaviour;
nothing here runs a behaviour. A ``Range`` is a closed interval (with its infinities) that
holds every value an expression can take, built from what the file, its world and its models
say: ``heading`` is in [-pi, pi], a pose within walls that enclose the world's bounds, a sonar
from 0 to its range or inf, a slider between its ends, a joint within its limits, an image's
size the camera's resolution, ``sin`` within [-1, 1], ``let`` signals through their
definitions. A comparison of such a value with a number known before the run that the range
makes always true or always false is a warning (``heading > 90``), and so is a trig function
given a known angle beyond a full turn (``sin(90)``, degrees where radians are meant). The
analysis is conservative: where it cannot bound a value, the range is everything, and a value
that may be ``nan`` (which every comparison but ``!=`` finds false) never "always holds".
"""
from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass, replace
from typing import Any

from labsim.backends.scene.models import Kind
from labsim.backends.scene.world import World
from labsim.dsl.analysis.check import Checked
from labsim.dsl.library.builtins import READ_BACK, Type
from labsim.dsl.syntax import ast
from labsim.foundation.source import Place, Text

INF = math.inf
# Physical readings can pass their nominal bound a little (a soft joint limit, a bump that
# pushes a robot): their ranges are widened by this fraction (of the top speed, of the joint's
# travel), so a threshold set at or just past the bound never warns.
SLACK = 0.05
_TRIG = frozenset({"sin", "cos", "tan"})
_FLIP = {"<": ">", "<=": ">=", ">": "<", ">=": "<=", "==": "==", "!=": "!="}
_HEADING = "heading is in radians, from -pi to pi (-180 to 180 degrees)"


@dataclass(frozen=True)
class Range:
    """Every value an expression can take is in [lo, hi], or nan where ``nan`` is set."""

    lo: float
    hi: float
    nan: bool = False
    facts: tuple[str, ...] = ()  # where the bounds come from, for the message
    angle: bool = False  # an angle in radians (heading, atan2): degree-size numbers get a hint

    @property
    def point(self) -> bool:
        return self.lo == self.hi and not self.nan


TOP = Range(-INF, INF, True)


def _facts(*ranges: Range) -> tuple[str, ...]:
    return tuple(dict.fromkeys(f for r in ranges for f in r.facts))[:3]


def _span(lo: float, hi: float, nan: bool, *of: Range) -> Range:
    """A range from bounds that may be nan (an infinity less itself): then it is everything."""
    if lo != lo or hi != hi:
        return TOP
    return Range(lo, hi, nan or any(r.nan for r in of), _facts(*of))


def _hull(ranges: Iterable[Range]) -> Range:
    rs = list(ranges)
    return Range(min(r.lo for r in rs), max(r.hi for r in rs), any(r.nan for r in rs), _facts(*rs))


def _monotone(f: Callable[[float], float], r: Range, nan: bool = False) -> Range:
    """f applied to a range, for a non-decreasing f defined on all of it."""
    try:
        return _span(f(r.lo), f(r.hi), nan, r)
    except (ArithmeticError, ValueError):
        return TOP


def add(a: Range, b: Range) -> Range:
    if (a.hi == INF and b.lo == -INF) or (a.lo == -INF and b.hi == INF):
        return TOP  # inf - inf is nan
    return _span(a.lo + b.lo, a.hi + b.hi, False, a, b)


def neg(a: Range) -> Range:
    return replace(a, lo=-a.hi, hi=-a.lo)


def mul(a: Range, b: Range) -> Range:
    def infinite(r: Range) -> bool:
        return r.lo == -INF or r.hi == INF

    if (infinite(a) and b.lo <= 0 <= b.hi) or (infinite(b) and a.lo <= 0 <= a.hi):
        return TOP  # inf * 0 is nan
    ends = [x * y for x in (a.lo, a.hi) for y in (b.lo, b.hi)]
    return _span(min(ends), max(ends), False, a, b)


def div(a: Range, b: Range) -> Range:
    if b.lo <= 0 <= b.hi or ((math.isinf(a.lo) or math.isinf(a.hi)) and (math.isinf(b.lo) or math.isinf(b.hi))):
        return TOP  # x / 0 is +-inf or nan; inf / inf is nan
    ends = [x / y for x in (a.lo, a.hi) for y in (b.lo, b.hi)]
    return _span(min(ends), max(ends), False, a, b)


def mod(a: Range, b: Range) -> Range:
    """x % k for a known k: Python's remainder has k's sign (and may round up to k itself)."""
    if not b.point or b.lo == 0 or math.isinf(b.lo):
        return TOP
    k = b.lo
    nan = math.isinf(a.lo) or math.isinf(a.hi)  # inf % k is nan
    return Range(min(0.0, k), max(0.0, k), nan or a.nan, _facts(a))


class Ranges(ast.Visitor[Range]):
    """The ranges of one checked behaviour's expressions, and the warnings they give.

    ``known`` is the linter's value of an expression known before the run (None otherwise);
    ``warn`` adds a warning at a place."""

    def __init__(self, c: Checked, known: Callable[[ast.Expr], Any],
                 warn: Callable[[Place, str], None]) -> None:
        self.c = c
        self.known = known
        self.warn = warn
        self.sliders = {sl.name: (sl.lo, sl.hi) for sl in c.sliders}
        self.let_exprs = {name: p.node for name, p in c.lets}
        # A let reads only the lets above it: each is worked out once, in order, on first need,
        # so a chain of lets costs one pass and no deep recursion.
        self.let_ranges: dict[str, Range] = {}

    # -- the warnings ------------------------------------------------------------------------
    def trig(self, e: ast.Call, text: Text) -> None:
        """sin(90): a known angle beyond a full turn is degrees where radians are meant."""
        if e.func not in _TRIG or len(e.args) != 1:
            return
        (arg,) = e.args
        value = self.known(arg)
        if isinstance(value, bool) or not isinstance(value, int | float):
            return
        if not math.isfinite(value) or abs(value) <= 2 * math.pi:
            return
        src = text.value[arg.span[0]:arg.span[1]]
        what = f"{src} is" if isinstance(arg, ast.Number) else f"'{src}' is {value:g},"
        self.warn(text.at(e.span), f"{e.func}() takes radians, and {what} more than a full turn (2*pi, "
                                   f"about 6.283); did you mean {e.func}(rad({src}))?")

    def compare(self, op: str, a: ast.Expr, b: ast.Expr, text: Text) -> None:
        """Warn when 'a op b', one side known before the run, holds always or never."""
        ka, kb = self.known(a), self.known(b)
        if (ka is None) == (kb is None):
            return  # both known: the linter's conditions say so; neither: nothing to compare with
        subject, limit, k = (a, b, kb) if kb is not None else (b, a, ka)
        if isinstance(k, bool) or not isinstance(k, int | float) or not math.isfinite(k):
            return  # '== inf', '< inf' are the idioms for 'sees nothing'
        r = self.of(subject)
        if not r.facts:
            return
        holds = _holds(r, op if subject is a else _FLIP[op], float(k))
        if holds is None or (holds and k in (r.lo, r.hi)):
            return  # a guard written at the range's own end (heading <= pi, sonar5 >= 0) is harmless
        start, end = a.span[0], b.span[1]
        source = text.value[start:end]
        verdict = "always holds" if holds else "never holds"
        said = "; ".join(r.facts)
        if not self.reading(subject):
            said = f"'{text.value[subject.span[0]:subject.span[1]]}' is {_between(r)}, since {said}"
        hint = ""
        if r.angle and abs(k) > math.pi and _holds(r, op if subject is a else _FLIP[op], math.radians(k)) is None:
            k0, k1 = limit.span[0] - start, limit.span[1] - start
            hint = f"; did you mean {source[:k0]}rad({source[k0:k1]}){source[k1:]}?"
        self.warn(text.at((start, end)), f"'{source}' {verdict}: {said}{hint}")

    def reading(self, e: ast.Expr) -> bool:
        """Whether e is a name or field its range's facts speak of by name (not a let signal)."""
        if isinstance(e, ast.Attribute) and isinstance(e.value, ast.Name):
            return e.value.id in self.c.channel_kinds
        return isinstance(e, ast.Name) and e.id not in self.let_exprs

    # -- ranges ------------------------------------------------------------------------------
    def of(self, e: ast.Expr) -> Range:
        """The range of an expression (TOP where nothing bounds it)."""
        value = self.known(e)
        if isinstance(value, int | float) and not isinstance(value, bool):
            v = float(value)
            return Range(v, v, v != v)
        return self.visit(e)

    def visit_Name(self, e: ast.Name) -> Range:
        return self.name(e.id)

    def visit_Neg(self, e: ast.Neg) -> Range:
        return neg(self.of(e.operand))

    def visit_Binary(self, e: ast.Binary) -> Range:
        a, b = self.of(e.left), self.of(e.right)
        ops: dict[str, Callable[[Range, Range], Range]] = {
            "+": add, "-": lambda x, y: add(x, neg(y)), "*": mul, "/": div, "%": mod}
        r = ops[e.op](a, b) if e.op in ops else TOP
        if e.op in ("+", "-") and (a.point or b.point):  # an angle moved by a constant is still one
            r = replace(r, angle=a.angle or b.angle)
        return r

    def visit_IfExp(self, e: ast.IfExp) -> Range:
        return _hull((self.of(e.body), self.of(e.orelse)))

    def visit_Call(self, e: ast.Call) -> Range:
        return self.call(e)

    def visit_Attribute(self, e: ast.Attribute) -> Range:
        return self.attribute(e)

    def visit_Peer(self, e: ast.Peer) -> Range:
        """Another robot's pose has the range of this one's (its start pose is in it too); its signal
        may be the 0 of the first tick, outside the signal's own range: none."""
        return self.name(e.attr) if e.attr in ("x", "y", "heading") else TOP

    # numbers known before the run are found above; booleans, text and groups have no range, nor
    # has a member of a group (its members' ranges are not followed)
    generic = frozenset({ast.Number, ast.Bool, ast.Not, ast.Compare, ast.BoolOp, ast.Text, ast.Group, ast.Index,
                         ast.Slice})

    def generic_visit(self, e: ast.Expr, *args: object) -> Range:
        return TOP

    def name(self, name: str) -> Range:
        """A name's range: a let, a slider, a reading or a built-in variable."""
        if name in self.let_exprs:
            if name not in self.let_ranges:
                for let in self.let_exprs:  # the lets above first, in order
                    if let not in self.let_ranges:
                        self.let_ranges[let] = TOP  # while it is worked out: prev(n, 0) inside n reads TOP
                        self.let_ranges[let] = self.of(self.let_exprs[let])
                    if let == name:
                        break
            return self.let_ranges.get(name, TOP)
        if name in self.sliders:
            lo, hi = self.sliders[name]
            return Range(lo, hi, facts=(f"slider '{name}' goes from {lo:g} to {hi:g}",))
        if name in ("time", "tick", "state_time"):
            what = "counts ticks" if name == "tick" else "counts seconds"
            return Range(0.0, INF, facts=(f"{name} {what} from 0",))
        kind = self.c.channel_kinds.get(name)
        if kind is Kind.DISTANCE:
            return self.sonar(name)
        if kind is Kind.REFLECTANCE:
            return Range(0.0, 1.0, facts=(f"{name} is a ground sensor's reflectance, from 0 (black) to 1 (white)",))
        if name == "heading":
            return Range(-math.pi, math.pi, facts=(_HEADING,), angle=True)
        if name in ("x", "y"):
            return self.pose(name)
        if name in READ_BACK and self.c.file.version >= 1.3 and self.c.models:
            return self.read_back(name)
        if name == "forward_speed" and self.c.models:
            models = self.c.models.values()
            v = max(m.max_wheel_speed_rad_s * m.wheel_radius_m for m in models)
            m = max(models, key=lambda m: m.max_wheel_speed_rad_s * m.wheel_radius_m)
            return Range(-v * (1 + SLACK), v * (1 + SLACK), facts=(
                f"forward_speed is in m/s, at most {v:.4g} either way ({m.name}'s max_wheel_speed "
                f"{m.max_wheel_speed_rad_s:g} rad/s times its wheel radius {m.wheel_radius_m:g} m)",))
        return TOP

    def read_back(self, name: str) -> Range:
        """Format 1.3: a wheel command as sent, within the wheels' limit; the start pose, as the pose."""
        if name == "start_heading":
            return Range(-math.pi, math.pi, facts=("start_heading is in radians, from -pi to pi (-180 to 180 "
                                                   "degrees)",), angle=True)
        if name in ("start_x", "start_y"):
            r = self.pose(name[-1])
            return replace(r, facts=tuple(f.replace(f"{name[-1]} is", f"{name} is", 1) for f in r.facts))
        model = max(self.c.models.values(), key=lambda m: m.max_wheel_speed_rad_s)
        v = model.max_wheel_speed_rad_s
        return Range(-v, v, facts=(f"{name} is in rad/s, at most {v:g} either way ({model.name}'s max_wheel_speed: "
                                   "a command is held to it)",))

    def sonar(self, name: str) -> Range:
        ranges = [s.range_m for m in self.c.models.values() for s in m.rays() if s.name == name]
        if not ranges:
            return TOP
        return Range(0.0, INF, facts=(f"{name} reads from 0 to {max(ranges):g} m (the model's range_m), "
                                      "or inf when it sees nothing",))

    def pose(self, name: str) -> Range:
        """x or y: within the world's bounds, when walls run all around them (else a robot may leave)."""
        world = self.c.world
        if world is None or not enclosed(world):
            return TOP
        xmin, ymin, xmax, ymax = world.bounds
        lo, hi = (xmin, xmax) if name == "x" else (ymin, ymax)
        return Range(lo, hi, facts=(f"{name} is in metres, from {lo:g} to {hi:g} (the walls around "
                                    f"world '{world.name}')",))

    def attribute(self, e: ast.Attribute) -> Range:
        """A joint's position within its limits; a centroid's .x, .y within its image."""
        if isinstance(e.value, ast.Name) and self.c.channel_kinds.get(e.value.id) is Kind.JOINT:
            world = self.c.world
            mechanism = world.mechanism if world is not None else None
            if e.attr != "position" or mechanism is None:
                return TOP
            joint = mechanism.joint(e.value.id)
            if joint.limits is None:
                return TOP
            lo, hi = joint.limits
            unit = "rad" if joint.angular else "m"
            slack = (hi - lo) * SLACK
            return Range(lo - slack, hi + slack, facts=(
                f"{joint.name}.position is in {unit}, within the joint's limits {lo:g} to {hi:g}",))
        if isinstance(e.value, ast.Name) and self.c.channel_kinds.get(e.value.id) is Kind.FORCE:
            return Range(0.0, INF, facts=(f"{e.value.id}.force is a tension in N, never negative",))
        if e.attr in ("x", "y"):
            centroid = self.centroid_of(e.value)
            size = self.image(centroid) if centroid is not None else None
            if size is not None:
                w, h, exact = size
                n = w if e.attr == "x" else h
                # An empty image's centroid (a crop outside the image) is its centre, -0.5.
                return Range(0.0 if exact else -0.5, n - 1.0, facts=(_resolution(size),))
        return TOP

    def centroid_of(self, e: ast.Expr, depth: int = 0) -> ast.Expr | None:
        """The image of 'centroid(img)', through lets; None when e is not one."""
        if isinstance(e, ast.Name) and e.id in self.let_exprs and depth < 100:
            return self.centroid_of(self.let_exprs[e.id], depth + 1)
        if isinstance(e, ast.Call) and e.func == "centroid" and e.args:
            return e.args[0]
        return None

    def call(self, e: ast.Call) -> Range:
        """A call's range from its arguments' (TOP for what keeps state or draws at random)."""
        f = e.func
        if len(e.args) == 1 and self.c.node_types.get(id(e.args[0])) in (Type.NUMBERS, Type.BOOLS):
            return TOP  # a reduction of a group (mean(front) is no image's mean): not followed
        if f in ("mean", "area", "width", "height"):
            return self.image_number(f, e.args[0])
        args = [self.of(a) for a in e.args]
        any_nan = any(r.nan for r in args)
        if f in ("sin", "cos"):
            r = args[0]
            return Range(-1.0, 1.0, any_nan or math.isinf(r.lo) or math.isinf(r.hi),
                         (f"{f}() is from -1 to 1",))
        if f == "atan2":
            return Range(-math.pi, math.pi, any_nan, ("atan2() is an angle in radians, from -pi to pi",), True)
        if f == "abs":
            r = args[0]
            lo = 0.0 if r.lo <= 0 <= r.hi else min(abs(r.lo), abs(r.hi))
            return Range(lo, max(abs(r.lo), abs(r.hi)), r.nan, _facts(r) or ("abs() is never negative",), r.angle)
        if f in ("min", "max"):
            pick = min if f == "min" else max
            return Range(pick(r.lo for r in args), pick(r.hi for r in args), any_nan, _facts(*args))
        if f == "clamp":
            x, low, high = args
            if low.nan or high.nan:
                return TOP
            return Range(min(low.lo, high.lo), max(low.hi, high.hi), x.nan,
                         _facts(low, high) or ("clamp(x, lo, hi) keeps x within lo and hi",))
        if f in ("deg", "rad", "floor", "ceil", "round", "sign", "exp"):
            impl: Callable[[float], float] = {
                "deg": math.degrees, "rad": math.radians, "floor": _whole(math.floor),
                "ceil": _whole(math.ceil), "round": _whole(round), "exp": math.exp,
                "sign": lambda v: float((v > 0) - (v < 0))}[f]
            return _monotone(impl, args[0])
        if f in ("sqrt", "log"):
            r = args[0]
            least = max(r.lo, 0.0)
            fn = math.sqrt if f == "sqrt" else (lambda v: -INF if v == 0 else math.log(v))
            return _monotone(fn, replace(r, lo=least, hi=max(r.hi, least)), r.lo < 0)
        return self.drawn_or_kept(f, args)

    def drawn_or_kept(self, f: str, args: list[Range]) -> Range:
        """Random draws and the memory functions that pass a value on."""
        if f == "random":
            return Range(0.0, 1.0, facts=("random() is from 0 to 1",))
        if f in ("uniform", "randint"):
            r = _hull(args)
            return replace(r, nan=r.nan or f == "randint")  # randint's bounds may have no whole number
        if f == "held":
            return Range(0.0, INF, facts=("held() counts seconds from 0",))  # of a boolean: never nan
        if f == "prev" or (f == "remember" and len(args) == 3):
            return _hull((args[0], args[-1]))
        return TOP

    # -- images ------------------------------------------------------------------------------
    def image_number(self, f: str, img: ast.Expr) -> Range:
        size = self.image(img)
        exact = size is not None and size[2]
        if f == "mean":  # an empty image (a crop outside it) has no mean: nan
            return Range(0.0, 255.0, not exact, ("mean() of an image is from 0 to 255",))
        if size is None:
            return Range(0.0, INF, facts=(f"{f}() is never negative",)) if f == "area" else TOP
        w, h, _ = size
        most = {"area": w * h, "width": w, "height": h}[f]
        lo = float(most) if exact and f != "area" else 0.0
        return Range(lo, float(most), facts=(_resolution(size),))

    def image(self, e: ast.Expr, depth: int = 0) -> tuple[int, int, bool] | None:
        """(width, height, exact) of an image expression: a camera's, through gray, threshold and
        invert (exact) and crop (at most); None when not known."""
        if isinstance(e, ast.Name):
            if e.id in self.let_exprs:
                return self.image(self.let_exprs[e.id], depth + 1) if depth < 100 else None
            sizes = {(c.width_px, c.height_px) for m in self.c.models.values() for c in m.cameras if c.name == e.id}
            return (*sizes.pop(), True) if len(sizes) == 1 else None
        if isinstance(e, ast.Call) and e.args and e.func in ("gray", "threshold", "invert", "crop"):
            size = self.image(e.args[0], depth + 1)
            return size if size is None or e.func != "crop" else (size[0], size[1], False)
        return None


def _holds(r: Range, op: str, k: float) -> bool | None:
    """Whether 'value op k' holds for every value in r (True), for none (False), or depends (None)."""
    if op == "!=":
        inside = _holds(r, "==", k)
        return None if inside is None else not inside
    always = {"<": r.hi < k, "<=": r.hi <= k, ">": r.lo > k, ">=": r.lo >= k,
              "==": r.lo == r.hi == k}[op]
    never = {"<": r.lo >= k, "<=": r.lo > k, ">": r.hi <= k, ">=": r.hi < k,
             "==": k < r.lo or k > r.hi}[op]
    if never:
        return False
    if always and not r.nan:  # nan compares false
        return True
    return None


def _between(r: Range) -> str:
    if r.lo == -INF:
        return f"at most {r.hi:.4g}"
    if r.hi == INF:
        return f"at least {r.lo:.4g}"
    return f"{r.lo:.4g}" if r.lo == r.hi else f"from {r.lo:.4g} to {r.hi:.4g}"


def _resolution(size: tuple[int, int, bool]) -> str:
    w, h, exact = size
    crop = "" if exact else ", or a crop of it"
    return f"the camera's image is {w} x {h} pixels{crop}"


def _whole(f: Callable[[float], Any]) -> Callable[[float], float]:
    """floor, ceil, round as the language has them: an infinity is itself."""
    return lambda v: v if math.isinf(v) else float(f(v))


def enclosed(world: World) -> bool:
    """Whether walls run along every edge of the world's bounds, so no robot leaves them."""
    xmin, ymin, xmax, ymax = world.bounds
    edges = ((0, ymin, 1, xmin, xmax), (0, ymax, 1, xmin, xmax), (1, xmin, 0, ymin, ymax),
             (1, xmax, 0, ymin, ymax))  # (fixed axis, its value, running axis, from, to)
    for fixed, at, run, start, end in edges:
        pieces = sorted((min(w.a[run], w.b[run]), max(w.a[run], w.b[run])) for w in world.walls
                        if abs(w.a[fixed] - at) < 1e-9 and abs(w.b[fixed] - at) < 1e-9)
        reach = start
        for a, b in pieces:
            if a > reach + 1e-9:
                break
            reach = max(reach, b)
        if reach < end - 1e-9:
            return False
    return True
