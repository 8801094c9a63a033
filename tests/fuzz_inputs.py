"""What the fuzz tests feed labsim, and the one way they feed it.

Two kinds of input, both hypothesis strategies:

- ``mutated()``: a shipped behaviour, a test fixture or a world file with a few bytes
  changed, inserted, deleted or replaced by a hostile token (a huge integer, 1e309, deep
  brackets), or one of its numbers replaced by one at the edges (``HOSTILE_NUMBERS``).
  Mostly these are broken files; the point is that each break is a diagnostic.
- ``generated()``: a behaviour file whose ``let:``, ``stop:``, ``rules:`` and ``metrics:``
  strings follow the productions of the language's grammar (``dsl/syntax/grammar.lark``), with names
  drawn from the language's built-ins and numbers from the edges of a float, so that many of
  them check and run.
- ``generated_12()``: a file of format 1.2, with the constructs that version added: groups
  (ranges, lists, a list of 40) with parameters and run-time values as places, functions over
  groups, signals that read themselves, ``when`` rules whose logs have format fields.
- ``generated_13()``: a file of format 1.3 with list parameters (some of the wrong shape) indexed at
  places from the edges, per-robot starts, read-back, and a ``--set`` of its list.
- ``generated_member_wise()``: a file of format 1.3 whose built-ins and functions are given groups
  member by member (with memory and random ones, groups of two sizes) and whose groups are sliced,
  bounds in and out of range.

A third kind, ``sweep_options()``, is what a user types after ``labsim sweep``: ``--set``
values, lists and START:STOP:STEP ranges, and ``--seeds``, from ordinary to hostile (huge,
infinite, not-a-number, negative, overflowing, empty, odd separators); ``check_sweep_options``
takes them through every check a sweep makes before it runs, and builds the grid when it is
small (docs/sweep.md, "Limits").

``run_input`` writes one input to a folder and takes it as far as it goes: compile (which
reads, checks and lints), then a few ticks on the pymunk backend with a trace, and the
summary. ``ALLOWED`` are the only exceptions it may raise; tests/hostile/test_fuzz.py runs a short
profile in the suite, tests/fuzz_long.py the long one.
"""
from __future__ import annotations

import functools
import re
from dataclasses import dataclass
from pathlib import Path

from hypothesis import strategies as st

from labsim.backends import load_backend
from labsim.backends.protocol import BackendError
from labsim.dsl.library.builtins import ACTIONS, FUNCTIONS, JOINT_ACTIONS, Type
from labsim.foundation.diagnostics import LabsimError
from labsim.runtime.run import compile_behaviour
from labsim.runtime.summary_json import summary_dict

ROOT = Path(__file__).resolve().parent.parent
ALLOWED = (LabsimError, BackendError)  # the project's own errors: a diagnostic, never a crash
TICKS = 5  # enough to run signals, decide, metrics and the trace; cheap enough for many inputs

# Tokens a mutation may splice in: numbers that do not fit, malformed scalars, deep nesting.
HOSTILE = (
    "1e309", "-1e309", "1" * 400, "9" * 5000, "0x" + "f" * 300, "0b_", "0o", "._", "1_", "nan", ".inf",
    "-.inf", "1:2:3", "0x", "+", "-", "2001-12-14", "[" * 200, "{" * 200, "- " * 100, "~", "!!binary", "&a",
    "*a", "'", '"', "\t", "\x00", "\ufeff", "é", "\n", ": ", "#", "?", "|", ">", "%", "@", "`",
    "/" * 300 + "x.yaml", "a" * 300 + ".yaml", "../", "/dev/null", "**", "randint(0, 1e300)", "9" * 40,
)
# Numbers a mutation puts in place of a number of the file: the edges of a float, and scalars
# that YAML 1.1's patterns read as numbers but cannot convert.
HOSTILE_NUMBERS = ("1e309", "-1e309", "1" * 400, "9" * 5000, "0x" + "f" * 300, "0b_", "0x_", "0o_", "._", "1_",
                   ".inf", "-.inf", ".nan", "9" * 40, "1e-400", "-0", "1:2:3", "0", "1e308", "2.5")


@dataclass(frozen=True)
class Seed:
    """A file labsim ships, as the start of mutations."""

    name: str
    text: str
    world: bool  # a world file: run through a behaviour that names it


@functools.lru_cache(maxsize=1)
def seeds() -> tuple[Seed, ...]:
    files = [*sorted((ROOT / "behaviours").glob("*.yaml")), *sorted((ROOT / "tests" / "fixtures").glob("*.yaml")),
             *sorted((ROOT / "backends" / "scene" / "worlds").glob("*.yaml"))]
    return tuple(Seed(p.name, p.read_text(), "labsim-world:" in p.read_text()) for p in files)


def _host(mechanism: bool) -> str:
    """The behaviour that runs a (mutated) world file, written beside it as world.yaml."""
    if mechanism:
        crane = (ROOT / "behaviours" / "crane.yaml").read_text()
        return re.sub(r"(?m)^world: .*$", "world: world.yaml", crane)
    return "labsim: 1\nname: host\nworld: world.yaml\nstop: time >= 1\nrobots:\n" \
           "  r: {model: pioneer_p3dx, at: random}\nrules:\n  - always move(2)\n"


def _mutate(data: bytes, ops: list[tuple[int, int, int, int]]) -> bytes:
    """Apply byte edits: (kind, where, byte, token) each, positions taken modulo the length."""
    out = bytearray(data)
    for kind, where, byte, token in ops:
        at = where % (len(out) + 1)
        if kind == 0:  # replace a byte
            out[at:at + 1] = bytes([byte])
        elif kind == 1:  # insert a byte
            out[at:at] = bytes([byte])
        elif kind == 2:  # delete a run of bytes
            del out[at:at + 1 + byte % 8]
        elif kind == 3:  # splice in a hostile token
            out[at:at] = HOSTILE[token % len(HOSTILE)].encode()
        elif kind == 4:  # replace a token of the file (a number, a name) by a hostile one
            spans = [m.span() for m in re.finditer(rb"[0-9A-Za-z_.]+", bytes(out))]
            if spans:
                s, e = spans[where % len(spans)]
                out[s:e] = HOSTILE[token % len(HOSTILE)].encode()
        else:  # replace a number of the file by one at the edges
            spans = [m.span() for m in re.finditer(rb"(?<![\w.])-?[0-9][0-9.eE+_-]*", bytes(out))]
            if spans:
                s, e = spans[where % len(spans)]
                out[s:e] = HOSTILE_NUMBERS[token % len(HOSTILE_NUMBERS)].encode()
    return bytes(out)


@st.composite
def mutated(draw: st.DrawFn) -> tuple[str, bytes, bool]:
    """(seed name, mutated bytes, whether it is a world file)."""
    seed = draw(st.sampled_from(seeds()))
    ops = draw(st.lists(st.tuples(st.integers(0, 5), st.integers(0, 1 << 16), st.integers(0, 255),
                                  st.integers(0, 255)), min_size=1, max_size=4))
    return seed.name, _mutate(seed.text.encode(), ops), seed.world


# -- behaviour files from the grammar --------------------------------------------------------

NUMERIC_NAMES = ("sonar5", "sonar8", "time", "tick", "front", "big", "k", "s", "x", "y", "heading", "index",
                 "state_time")
NUMBERS = ("0", "1", "2", "0.5", "1e308", "1e309", "9" * 30, "9" * 400, "1e-320", "360", "100", ".5", "3.", "1", "2",
           "0.1", "10")
ORDINARY = ("0", "1", "2", "0.5", "360", "100", ".5", "3.", "0.1", "10")  # NUMBERS that fit a float


def _typed(functions: dict[str, tuple[Type, ...]], returns: Type,
           parts: dict[Type, st.SearchStrategy[str]]) -> list[st.SearchStrategy[str]]:
    """Calls of the built-ins that return ``returns``, each with arguments of its types."""
    out = []
    for name, params in functions.items():
        if all(p in parts for p in params):
            out.append(st.tuples(*(parts[p] for p in params)).map(lambda a, f=name: f"{f}({', '.join(a)})"))
    return out


def _expressions() -> tuple[st.SearchStrategy[str], st.SearchStrategy[str]]:
    """(number, condition) expression strings in the grammar's shapes, mostly well typed.

    Well typed, so that most of them pass the checker and reach generated code, where the
    numbers at a float's edges (NUMBERS) are what is being tried; the mutations cover the rest.
    """
    by_type: dict[Type, dict[str, tuple[Type, ...]]] = {Type.NUMBER: {}, Type.BOOL: {}}
    for f in FUNCTIONS.values():
        if f.returns in by_type and not f.variadic:
            by_type[f.returns][f.name] = f.params
    numbers = st.one_of(st.sampled_from(NUMBERS), st.sampled_from(NUMERIC_NAMES))
    conditions = st.one_of(st.sampled_from(("true", "false", "detected(sonar5)", "state == follow")))

    def extend(e: st.SearchStrategy[str]) -> st.SearchStrategy[str]:
        # one level up, from numbers e: numbers and conditions both, as a pair of choices
        cond = st.one_of(conditions, st.builds("{} {} {}".format, e, st.sampled_from(("<", "<=", "==", "!=", ">")), e))
        parts = {Type.NUMBER: e, Type.BOOL: cond}
        return st.one_of(
            st.builds("{} {} {}".format, e, st.sampled_from(("+", "-", "*", "/", "%", "**")), e),
            st.builds("-{}".format, e), st.builds("({})".format, e),
            st.builds("{} if {} else {}".format, e, cond, e),
            st.builds(lambda f, a: f"{f}({', '.join(a)})", st.sampled_from(("min", "max")), st.lists(e, min_size=2,
                                                                                                   max_size=4)),
            *_typed(by_type[Type.NUMBER], Type.NUMBER, parts))

    number = st.recursive(numbers, extend, max_leaves=10)
    parts = {Type.NUMBER: number, Type.BOOL: conditions}
    condition = st.one_of(
        st.builds("{} {} {}".format, number, st.sampled_from(("<", "<=", "==", "!=", ">", ">=")), number),
        conditions, st.builds("not ({})".format, conditions),
        st.builds("{} and {} or {}".format, conditions, conditions, conditions),
        *_typed(by_type[Type.BOOL], Type.BOOL, parts))
    return number, condition


@functools.lru_cache(maxsize=3)
def _strings(start: str) -> st.SearchStrategy[str]:
    """Strings for a start rule of the grammar: 'expr' (a number), 'condition' or 'rule'.

    Built from the grammar's productions by hand rather than with hypothesis.extra.lark's
    from_lark, which took half a second an expression here and glues tokens without the
    blanks the lexer needs (``0if0else0``), so that few of its strings reach the checker.
    """
    expr, condition = _expressions()
    if start == "expr":
        return expr
    if start == "condition":
        return condition
    log = st.sampled_from(('"t={time:.1f} s={s}"', "'{big}'", '"{k:.300f}"', '"plain"', '"{big:d}"', '"{s:.1%}"'))
    wheels = [st.tuples(*[expr] * len(a.params)).map(lambda args, n=a.name: f"{n}({', '.join(args)})")
              for a in ACTIONS.values() if a.name not in JOINT_ACTIONS and a.name != "log"]
    action = st.one_of(st.builds("goto {}".format, st.sampled_from(("follow", "wander"))), *wheels,
                       st.builds("log({})".format, log))
    actions = st.one_of(action, st.builds("goto follow, {}".format, action))
    return st.one_of(st.builds("if {} then {}".format, condition, actions), st.builds("else {}".format, actions))


def _quoted(text: str) -> str:
    return "'" + text.replace("'", "''") + "'"


@st.composite
def generated(draw: st.DrawFn) -> str:
    """A behaviour file whose strings follow the grammar, its numbers and names from the edges."""
    expr, condition, rule = _strings("expr"), _strings("condition"), _strings("rule")
    # ordinary values, and at most one from the edge per file: one odd value per file tells more,
    # and the others then reach the checker and the run
    odd = draw(st.sampled_from(("big", "seed", "count", "", "", "")))
    big = draw(st.sampled_from(NUMBERS if odd == "big" else ORDINARY))
    seed = draw(st.sampled_from(("-1", "9" * 30, "1e309", "2.5") if odd == "seed" else ("1", "0", "7", "3")))
    count = draw(st.sampled_from(("0", "9" * 25) if odd == "count" else ("1", "2", "3")))
    lets = draw(st.lists(expr, min_size=1, max_size=3))
    rules = draw(st.lists(rule, min_size=1, max_size=3))
    stop = draw(st.one_of(condition, st.just("time >= 0.1")))
    metric = draw(st.one_of(condition.map("count({})".format), expr.map("maximum({})".format)))
    lines = ["labsim: 1", "name: generated", "world: walls_lab4", f"seed: {seed}", "dt: 0.05",
             f"stop: {_quoted(stop)}", "robots:", f"  r: {{model: pioneer_p3dx, at: random, count: {count}}}",
             "params:", f"  big: {big}", "  k: 2", "  front: 0.5", "let:",
             *(f"  s{i if i else ''}: {_quoted(t)}" for i, t in enumerate(lets)),
             "rules:", "  wander:", *(f"    - {_quoted(r)}" for r in rules), "  follow:", "    - always stop()",
             "metrics:", f"  m: {_quoted(metric)}"]
    return "\n".join(lines) + "\n"


# -- the constructs of language 1.2 -----------------------------------------------------------

GROUPS_12 = ("front", "side", "[sonar4, sonar5]", "sonar1..sonar8", "sonar8..sonar1", "[w, sonar5, k]", "sonar2..4",
             "[w, k, 0.5, sonar8]", "[" + ", ".join(["sonar1"] * 40) + "]", "front[k]", "(front - [1, 2, 3])")
PLACES_12 = ("k", "0", "7", "k - 1", "-1", "8", "pi", "dt", "k / 2", "tick % 9", "round(time)", "w", "1e309",
             "argmin(front)", "count(front < 1)", "inf - inf")
FUNCTIONS_12 = ("  near(g, d): count(g < d)", "  pick(g, i): g[i]", "  steer(x, gain): clamp(gain * x, -2, 2)",
                "  both(g, h): min(g - h)", "  later(g, i): pick(g, i + 1)", "  wide(g): g * 2")
FIELDS_12 = ("{time:d}", "{s:.2f}", "{argmin(front)}", "{'left' if s > 0 else 'right'}", "{state}", "{w:d}",
             "{front[k]:.1f}", "{near(front, 1):d}", "{k:.30f}", "{pick(front, k)}", "{w == k}", "{big:.1%}")


@st.composite
def generated_12(draw: st.DrawFn) -> str:
    """A behaviour file of format 1.2: groups with parameters as places, functions over groups,
    list groups, signals that read themselves, 'when' rules that log with format fields."""
    leaf = st.sampled_from(("sonar5", "k", "w", "time", "0.5", "2", "x", "heading", "big", "sonar8"))
    simple = st.recursive(leaf, lambda e: st.one_of(
        st.builds("{} {} {}".format, e, st.sampled_from(("+", "-", "*", "/", "%", "**")), e),
        st.builds("min({}, {})".format, e, e), st.builds("({})".format, e), st.builds("-{}".format, e)), max_leaves=4)
    expr = st.one_of(*[simple] * 9, _strings("expr"))  # now and then the edges of a float too
    condition = st.one_of(*[st.builds("{} < {}".format, simple, simple)] * 9, _strings("condition"))
    group = st.one_of(st.sampled_from(GROUPS_12),
                      st.builds("{} {} {}".format, st.sampled_from(GROUPS_12), st.sampled_from("+-*/"),
                                st.one_of(expr, st.sampled_from(GROUPS_12))),
                      st.builds("wide({})".format, st.sampled_from(GROUPS_12)))
    place = st.one_of(st.sampled_from(PLACES_12), expr)
    number = st.one_of(
        st.builds("{}({})".format, st.sampled_from(("min", "max", "sum", "mean", "argmin", "argmax")), group),
        st.builds("{}[{}]".format, st.sampled_from(("front", "side", "[sonar4, sonar5]", "(front - 1)")), place),
        st.builds("count({} < {})".format, group, expr), st.builds("near({}, {})".format, group, expr),
        st.builds("pick({}, {})".format, group, place), st.builds("later({}, {})".format, group, place),
        st.builds("both({}, {})".format, group, group), st.builds("steer({}, {})".format, expr, expr), expr)
    cond = st.one_of(st.builds("{} {} {}".format, number, st.sampled_from(("<", "==", "!=", ">=")), number),
                     st.builds("{}({} < {})".format, st.sampled_from(("any", "all")), group, expr),
                     st.sampled_from(("w == k", "w != 3", "rising(s > 1)", "front < 0.5")), condition)
    text = st.lists(st.one_of(st.sampled_from(FIELDS_12), st.sampled_from(("at ", " s", "{{", "\\x1b", "é"))),
                    min_size=1, max_size=4).map("".join)
    k = draw(st.sampled_from(("2", "2", "2", "1", "0", "1", "2", "1", "0", "1", "8", "0.5", "-1", "1e309")))
    lets = draw(st.lists(number, min_size=1, max_size=3))
    self_reading = draw(st.sampled_from((
        "prev(w, 0) + 1 if sonar5 < 0.5 else prev(w, 0)", "prev(w, 0) + sonar5 if prev(w, 0) < k else prev(w, k) - 1",
        "(prev(w, 0) + 1 if prev(w, 0) < k else 0) if detected(sonar8) else prev(w, 0)",
        "prev(w, 1) * 0.5 + sonar5" if draw(st.integers(0, 19)) else "w + 1")))
    functions = FUNCTIONS_12
    rules = [f"when {draw(cond)} then log(\"{draw(text)}\")" for _ in range(draw(st.integers(1, 2)))]
    rules += [f"if {draw(cond)} then arc({draw(number)}, {draw(expr)})", "else move(2)"]
    lines = ["labsim: 1.2", "name: generated", "world: walls_lab4", "seed: 3", "dt: 0.05", "stop: time >= 0.2",
             "robots:", f"  r: {{model: pioneer_p3dx, at: random, count: {draw(st.sampled_from(('1', '2')))}}}",
             "params:", f"  k: {k}", "  big: 2", "functions:", *sorted(functions),
             "let:", f"  front: {draw(st.sampled_from(('sonar1..sonar8', '[sonar4, sonar5, sonar6]')))}",
             "  side: [sonar8, sonar9]", f"  w: {_quoted(self_reading)}",
             *(f"  s{i if i else ''}: {_quoted(t)}" for i, t in enumerate(lets)),
             "rules:", "  wander:", *(f"    - {_quoted(r)}" for r in rules), "  follow:", "    - always stop()",
             "metrics:", f"  m: {_quoted(draw(cond.map('count({})'.format)))}"]
    return "\n".join(lines) + "\n"


# -- lists, per-robot starts and read-back (language 1.3) ------------------------------------

LISTS_13 = ("[[0, -1], [3, -1], [3, -4]]", "[[1, 2, 3]]", "[0.5, 1, 2]", "[7]", "[[0, -1], [3]]", "[]", "[[]]",
            "[1, [2]]", "[[1e309, 0]]", "[[0, x]]", "[true, 1]", "[[[1]]]", "[" + ", ".join(["[1, 2]"] * 60) + "]")
PLACES_13 = ("0", "1", "2", "k", "k - 1", "-1", "3", "0.5", "len(w)", "len(w) - 1", "tick % 4", "round(time * 9)",
             "inf - inf", "1e309", "prev(s, 0)", "w[0][0]", "randint(0, 2)")
STARTS_13 = ("[[-3, -3, 0], [0, -3, 90]]", "[[-3, -3], [0, -3, 90]]", "[[-3, -3, 0]]", "[[-3, -3, 0], [-3, -3, 0]]",
             "[[-3, -3, 0], [30, 0]]", "[[-3, -3, 0], spawn]", "[[-3, -3, 0], [1, 2, 3, 4]]", "random")
SETS_13 = ("", "", "", "[[1, 2], [3, 4]]", "3", "[1, 2]", "[[1, 2]", "[[1, 2], [3]]", "[]", "{a: 1}")


@st.composite
def generated_13(draw: st.DrawFn) -> tuple[str, dict[str, str]]:
    """A behaviour file of format 1.3 with its lane's constructs, and a ``--set`` of its list: list
    parameters of every shape (some wrong), rows and numbers of them at places from the edges, len(),
    a start pose per robot (some wrong), and the wheels and start pose read back."""
    # mostly lists of a good shape and places that are theirs, so that many files run; now and then any
    odd = draw(st.integers(0, 9)) == 0
    w = draw(st.sampled_from(LISTS_13)) if odd else draw(st.sampled_from(("[[0, -1], [3, -1], [3, -4]]",
                                                                          "[[2, 2.5], [1e300, -1e-300]]")))
    g = draw(st.sampled_from(LISTS_13)) if odd else "[0.5, 1, 2]"
    place = st.one_of(*[st.sampled_from(("0", "1", "k", "tick % 4", "len(w) - 1", "s % 3"))] * 6,
                      st.sampled_from(PLACES_13))
    number = st.one_of(
        st.builds("w[{}][{}]".format, place, place), st.builds("min(w[{}])".format, place),
        st.builds("sum(w[{}] * 2)".format, place), st.builds("g[{}]".format, place), st.just("len(w) + len(g)"),
        st.builds("hypot(w[{}][0] - x, w[{}][1] - y)".format, place, place),
        st.sampled_from(("wheel_left", "wheel_right - wheel_left", "start_x", "start_heading + heading",
                         "max(g)", "mean(g - start_y)")))
    lets = draw(st.lists(number, min_size=1, max_size=4))
    count = draw(st.sampled_from(("1", "2", "2", "3")) if odd else st.just("2"))
    lines = ["labsim: 1.3", "name: generated", "world: walls_lab4", "seed: 3", "dt: 0.05", "stop: time >= 0.2",
             "robots:", f"  r: {{model: pioneer_p3dx, count: {count}, at: "
             f"{draw(st.sampled_from(STARTS_13)) if odd else 'random'}}}",
             "params:", f"  w: {w}", f"  g: {g}", f"  k: {draw(st.sampled_from(('0', '1', '2', '5', '0.5')))}",
             "let:", f"  s: {_quoted('prev(s, 0) + 1 if sonar5 < 1 else prev(s, 0)')}",
             *(f"  s{i}: {_quoted(t)}" for i, t in enumerate(lets)),
             "rules:", f"  - if {_quoted(draw(number))[1:-1]} > 1 then arc(wheel_left + 1, 2)", "  - else move(100)"]
    setting = draw(st.sampled_from(SETS_13)) if odd or draw(st.integers(0, 4)) == 0 else ""
    return "\n".join(lines) + "\n", ({"w": setting} if setting else {})


# -- member by member, and slices (language 1.3) --------------------------------------------------

SLICES_13 = ("front[0:4]", "front[:2]", "front[4:]", "front[:]", "front[k:k + 2]", "side[0:1]", "front[2:2]",
             "front[3:1]", "front[0:9]", "front[-1:2]", "front[0.5:2]", "front[w:3]", "sonar5[0:1]",
             "(front - 1)[1:3]", "lidar1..lidar8[2:6]", "front[0:4][1:3]", "[sonar1, k, 2][1:]")
MEMBER_WISE_13 = ("clamp({g}, 0, 1)", "abs({g} - 0.5)", "min({g}, k)", "max({g}, {h})", "near({g})",
                  "rising({g} < 0.5)", "counter({g} < 0.5)", "total({g} * dt)", "prev({g}, 0)",
                  "hold({g} < 0.5, k > 1)",
                  "pid({g} - 0.5, 1, 0, 0)", "gauss({g}, 0.1)", "uniform({g}, {h})", "held({g} < w)",
                  "randint({g}, 3)", "clamp({g}, {h}, 1)", "sqrt({g})", "remember({g}, w > 0)", "sign({g}) * 2")
REDUCED_13 = ("min({})", "max({})", "sum({})", "mean({})", "argmin({})", "count({} > 0)", "any({} > 1)", "{}[1]",
              "{}[k]")


@st.composite
def generated_member_wise(draw: st.DrawFn) -> str:
    """A file of format 1.3: built-ins and a function of its own given groups member by member, memory
    and random ones among them, slices in and out of range, groups of two sizes paired; some of it
    used where a number is needed."""
    group = st.one_of(*[st.sampled_from(("front", "side", "front[0:3]", "sonar1..sonar3", "[sonar1, sonar2, k]"))] * 9,
                      st.sampled_from(SLICES_13))
    call = st.builds(lambda f, g, h: f.format(g=g, h=h), st.sampled_from(MEMBER_WISE_13), group, group)
    grouped = st.one_of(call, call, group, st.builds("clamp({}, 0, 1)".format, call))
    number = st.builds(lambda f, g: f.format(g), st.sampled_from(REDUCED_13), grouped)
    k = draw(st.sampled_from(("2", "1", "0", "4", "0.5", "-1", "7")))
    lets = draw(st.lists(st.one_of(grouped, number), min_size=1, max_size=3))
    rule = draw(st.one_of(*[number.map("if {} > 0.5 then arc(1, 2)".format)] * 9,
                          grouped.map("if {} then move(1)".format), grouped.map("always arc({}, 1)".format)))
    lines = ["labsim: 1.3", "name: generated", "world: walls_lab4", "seed: 3", "dt: 0.05", "stop: time >= 0.2",
             "robots:", f"  r: {{model: pioneer_p3dx, at: random, count: {draw(st.sampled_from(('1', '2')))}, "
             f"lidar: {{beams: 8, range_m: 2}}}}",
             "params:", f"  k: {k}", "functions:", "  near(d): d < 0.4",
             "let:", f"  front: {draw(st.sampled_from(('sonar1..sonar8', *['[sonar4, sonar5, sonar6]'] * 3)))}",
             "  side: [sonar8, sonar9, sonar10]", "  w: sonar5 - 0.5",
             *(f"  s{i}: {_quoted(t)}" for i, t in enumerate(lets)),
             "rules:", f"  - {_quoted(rule)}", "  - else move(2)",
             "metrics:", f"  m: {_quoted(draw(number.map('maximum({})'.format)))}"]
    return "\n".join(lines) + "\n"


@st.composite
def generated_13_robots(draw: st.DrawFn) -> str:
    """A behaviour file of format 1.3 whose robots read each other and talk: names of robots and of
    members (at places known before the run and only while running, in range or not), their
    pose, state and signals, say on channels with and without a range, heard with and without
    a default; and now and then a mistake (a robot, a member or a channel that is not there)."""
    count = draw(st.sampled_from(("1", "2", "3")))
    member = "r" if count == "1" else draw(st.sampled_from(("r[0]", "r[1]", "r[k]", "r[index + 1]", "r[index - 1]",
                                                             "r[2]", "r[tick % 3]", "r[sonar5]")))
    other = st.sampled_from((f"{member}.x", f"{member}.y", f"{member}.heading", f"{member}.s", f"{member}.near",
                             "leader.x", "leader.s", "leader.heading", "heard(c)", "heard(d, -1)", "heard(c, k)",
                             "leader.sonar5" if draw(st.integers(0, 29)) == 0 else "leader.y",
                             "heard(e)" if draw(st.integers(0, 29)) == 0 else "leader.x"))
    leaf = st.one_of(other, st.sampled_from(("x", "k", "time", "0.5", "sonar5", "inf")))
    expr = st.recursive(leaf, lambda e: st.one_of(
        st.builds("{} {} {}".format, e, st.sampled_from(("+", "-", "*", "/")), e),
        st.builds("atan2({}, {})".format, e, e), st.builds("({})".format, e)), max_leaves=4)
    state = draw(st.sampled_from((f"{member}.state == follow", "leader.state != wander", "leader.near")))
    reach = draw(st.sampled_from(("", ", 2", ", k", ", inf", ", sonar5", ", 0 - k", ", x - 100")))
    said = draw(st.sampled_from(("x", "1 / (tick - 2)", "s", "heard(c) + 1", "inf - inf")))
    rules = [f"when {state} then say(c, {said}{reach}), say(d, {draw(expr)})",
             f"if heard(c) > {draw(expr)} then arc(1, {draw(expr)}), say(c, tick)",
             "if time > 0.1 then goto follow", "else move(2)"]
    lines = ["labsim: 1.3", "name: generated", "world: walls_lab4", "seed: 3", "dt: 0.05", "stop: time >= 0.2",
             "robots:", "  leader: {model: pioneer_p3dx, at: [0, 0, 0]}",
             f"  r: {{model: pioneer_p3dx, at: random, count: {count}}}",
             "params:", f"  k: {draw(st.sampled_from(('0', '1', '2', '0.5', '-1')))}",
             "let:", f"  s: {_quoted(draw(expr))}", "  near: sonar5 < 0.5", f"  t: {_quoted(draw(expr))}",
             "rules:", "  wander:", *(f"    - {_quoted(r)}" for r in rules), "  follow:",
             f"    - {_quoted(f'always arc({draw(expr)}, 1)')}", "metrics:", "  m: maximum(t)"]
    return "\n".join(lines) + "\n"


# -- one input, as far as it goes ------------------------------------------------------------

def run_input(folder: Path, data: bytes, world: bool = False, overrides: dict[str, str] | None = None) -> str:
    """Compile and run one input in ``folder`` (with ``overrides``, as --set gives them); return how far it
    got ('error' or 'ran').

    Raises anything but ``ALLOWED``: that is a crash the fuzz tests report.
    """
    if world:
        (folder / "world.yaml").write_bytes(data)
        path = folder / "behaviour.yaml"
        path.write_text(_host(b"mechanism:" in data))
    else:
        path = folder / "behaviour.yaml"
        path.write_bytes(data)
        pendulum = ROOT / "tests" / "fixtures" / "pendulum_world.yaml"
        (folder / "pendulum_world.yaml").write_bytes(pendulum.read_bytes())
    try:
        compiled = compile_behaviour(path, overrides)
        warnings: list[str] = []
        bound = compiled.bind(load_backend("pymunk"), trace=folder / "trace.csv", warn=warnings.append)
        try:
            summary = bound.run(max_ticks=TICKS)
            summary_dict(summary)
        finally:
            bound.close()
    except ALLOWED:
        return "error"
    return "ran"


# -- a sweep's options -----------------------------------------------------------------------

SWEEP_NUMBERS = (*ORDINARY, *HOSTILE_NUMBERS, "inf", "-inf", "nan", "-0", "1e-300", "1e300", "1e16", "0.5000001",
                 "1e-10", "-1", "", " ", "1:2", "9007199254740993")
SMALL_GRID = 200  # a grid this small is built as well as counted


@st.composite
def sweep_options(draw: st.DrawFn) -> tuple[list[str], str | None]:
    """``--set`` options (0 to 3) and a ``--seeds`` (or none), as a user might type them."""
    number = st.sampled_from(SWEEP_NUMBERS)
    name = st.sampled_from(("front", "side", "minutes", "x", "", "front ", "a=b"))
    value = st.one_of(
        st.builds(lambda n, v: f"{n}={v}", name, st.lists(number, min_size=1, max_size=4).map(",".join)),
        st.builds(lambda n, a, b, c: f"{n}={a}:{b}:{c}", name, number, number, number),
        st.text(alphabet="=:,-.0123456789e ", max_size=12))
    sets = draw(st.lists(value, max_size=3))
    seed = st.one_of(number, st.builds(lambda a, b: f"{a}-{b}", number, number))
    seeds = draw(st.one_of(st.none(), st.lists(seed, min_size=1, max_size=4).map(",".join)))
    return sets, seeds


def check_sweep_options(sets: list[str], seeds: str | None) -> str:
    """Every check ``labsim sweep`` makes of its options before anything runs; then the grid, when
    it is small. 'error' or 'ok'; raises anything but ``ALLOWED``."""
    from labsim.runtime.sweep.driver import SweepOptions, check_options
    from labsim.runtime.sweep.grid import FileInfo, grid, grid_size

    files = [str(ROOT / "behaviours" / "wall_follow.yaml")]
    try:
        settings, seed_list = check_options(SweepOptions(files, sets, seeds))
    except ALLOWED:
        return "error"
    if grid_size(files, settings, seed_list) <= SMALL_GRID:
        tasks = grid(files, settings, seed_list, {files[0]: FileInfo(files[0], seed=1)})
        assert len(tasks) == grid_size(files, settings, seed_list)
    return "ok"
