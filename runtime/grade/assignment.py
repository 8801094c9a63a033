"""Assignment files: what a grader asks of every submission, read with positions (docs/grading.md).

The first stage of ``labsim grade``: the assignment file comes in through the one safe reader
(``labsim.foundation.source``, file kind ``assignment``) and becomes a frozen ``Assignment``:
the world and robots a submission must use (or ``any``), the params the grader sets, the
metrics it must define, the seeds, budgets and per-run timeout, and the criteria that turn a
submission's metrics into a score. Every mistake is reported at once, ``path:line:col``, as a
behaviour file's are; ``assignment_schema`` is the same table as a JSON Schema for editors.
"""
from __future__ import annotations

import hashlib
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from yaml.nodes import MappingNode, Node, ScalarNode, SequenceNode

from labsim.backends.scene.world_file import load_world
from labsim.backends.scene.world_names import WorldRef, builtin_worlds, find_world
from labsim.dsl.library.builtins import AGGREGATES, Better
from labsim.dsl.syntax import ast as dsl_ast
from labsim.dsl.syntax.parse import ParseError, parse_expr
from labsim.dsl.syntax.read import MetricDecl, Parsed
from labsim.foundation.diagnostics import LabsimError, Report, did_you_mean
from labsim.foundation.files import read_input
from labsim.foundation.kinds import ASSIGNMENT_VERSION_KEY, YAML_SUFFIXES, file_kind
from labsim.foundation.limits import DEFAULT_BUDGETS, Budgets
from labsim.foundation.numbers import WHOLE_LIMIT
from labsim.foundation.source import Reader, TextSpan, load, scalar_value
from labsim.runtime.grade.readable import LEN_WORDS, measurable_names, unreadable

KEYS = (ASSIGNMENT_VERSION_KEY, "title", "world", "robots", "params", "measure", "metrics", "seeds", "timeout_s",
        "budgets", "criteria", "gate_score", "reference")
CRITERION_KEYS = ("at_least", "at_most", "score", "weight", "required", "from")
STUDENT = "student"  # from: student, a criterion on a metric the student's file defines
# the built-in criteria: each reads every seed's run, not a metric
RAN_TO_STOP, NO_FAULTS, NO_COLLISIONS, MOVED = "ran_to_stop", "no_faults", "no_collisions", "moved"
BUILTINS = {RAN_TO_STOP: "ran to its stop condition on every seed",
            NO_FAULTS: "no runtime faults (nan, inf, a domain error) on any seed",
            NO_COLLISIONS: "no collisions on any seed",
            MOVED: "every robot drove at least the distance asked on every seed"}
ANY = "any"
MAX_SEEDS = 100
DEFAULT_TIMEOUT_S = 60.0
MAX_TIMEOUT_S = 3600.0  # an hour a run: a longer one is a mistake in the assignment, not a lab
MAX_PARAM = float(WHOLE_LIMIT)  # a grader's param value, either sign: 2**53, as for seeds
# what a measured metric may read besides the sensors: what no student's file can write
MEASURED_SUFFIX = " (measured)"  # a measured metric's name in a student's program: no file can write it


@dataclass(frozen=True)
class Criterion:
    """One line of the marking scheme: a metric's mean over the seeds against a threshold
    (``at_least``/``at_most``: all or nothing) or a scored range (``worst`` scores 0, ``best``
    the full weight, linear between), or a built-in criterion (all or nothing)."""

    name: str  # the metric's name, or a built-in's (BUILTINS)
    weight: float
    at_least: float | None = None
    at_most: float | None = None
    worst: float | None = None
    best: float | None = None
    required: bool = False  # a gate: failing it gives the assignment's gate_score whatever the rest
    student: bool = False  # from: student, a metric of the student's own file (else a measured one)

    @property
    def builtin(self) -> bool:
        return self.name in BUILTINS

    def describe(self) -> str:
        """The criterion in words, as the gradebook and the pages show it."""
        if self.builtin:
            if self.name == MOVED:
                return f"every robot drove at least {self.at_least or 0.0:g} m on every seed"
            return BUILTINS[self.name]
        if self.worst is not None:
            return f"{self.name}: 0 at {self.worst:g}, full at {self.best:g}"
        return f"{self.name} >= {self.at_least:g}" if self.at_least is not None else f"{self.name} <= {self.at_most:g}"

    def fraction(self, value: float) -> float:
        """How much of the weight a metric's value earns: 0 to 1 (a nan earns nothing; an inf is
        beyond any threshold, on the side it is)."""
        if math.isnan(value):
            return 0.0
        if self.at_least is not None:
            return float(value >= self.at_least)
        if self.at_most is not None:
            return float(value <= self.at_most)
        assert self.worst is not None and self.best is not None
        return min(1.0, max(0.0, (value - self.worst) / (self.best - self.worst)))


@dataclass(frozen=True)
class Assignment:
    """An assignment file, read and checked: see the module docstring and docs/grading.md."""

    path: str
    sha256: str  # of the file's text: a changed assignment grades every submission anew
    title: str
    world: str | None  # the world's name (a built-in's, or a world file's name); None: any
    robots: int | None  # how many robots; None: any
    params: Mapping[str, str]  # the params every submission declares, with the values the grader sets
    metrics: tuple[str, ...]  # the metrics every submission defines (the criteria's among them)
    seeds: tuple[int, ...]
    timeout_s: float  # wall time a run may take, per run
    budgets: Budgets
    criteria: tuple[Criterion, ...]
    reference: str | None = None  # a behaviour whose metrics are shown beside each student's
    measure: tuple[MetricDecl, ...] = ()  # the metrics the grader measures on every run (its own names)
    gate_score: float = 0.0  # the score (at most) of a student who fails a required criterion
    # the assignment's world file (a built-in's own file, or the teacher's) and the SHA-256 of its
    # bytes: a student's world must be this world, not another one of the same name
    world_file: str | None = None
    world_sha256: str = ""
    weights: float = field(init=False)

    @property
    def moves(self) -> bool:
        """Whether a criterion reads the distance each robot drove (the built-in ``moved``)."""
        return any(c.name == MOVED for c in self.criteria)

    @property
    def measured(self) -> tuple[str, ...]:
        return tuple(m.name for m in self.measure)

    def definition(self, metric: str) -> str:
        """A measured metric's formula, as the assignment writes it ('' for another)."""
        return next((" ".join(m.value.text.value.split()) for m in self.measure if m.name == metric), "")

    def __post_init__(self) -> None:
        object.__setattr__(self, "weights", sum(c.weight for c in self.criteria))


def read_assignment(path: str | Path) -> Assignment:
    """The assignment file at path; LabsimError with every problem in it."""
    doc = load(path, kind="assignment")
    report = Report()
    reader = _AssignmentReader(doc, report)
    found = reader.read()
    report.raise_if_errors()
    assert found is not None
    return found


class _AssignmentReader(Reader):
    _aggregates: dict[str, str]  # a measured metric's aggregate (count, duration, ...), by name

    def read(self) -> Assignment | None:
        self._aggregates = {}
        root = self.doc.root
        if root is None:
            self.error(None, "the file is empty: an assignment file is a YAML mapping that starts with "
                             f"'{ASSIGNMENT_VERSION_KEY}: 1' (docs/grading.md)")
            return None
        keys = self.fields(root, KEYS, "an assignment file")
        if keys is None:
            return None
        for required in (ASSIGNMENT_VERSION_KEY, "world", "robots", "criteria"):
            if required not in keys:
                self.error(None, f"missing required key '{required}:'", notes=("docs/grading.md",))
        if ASSIGNMENT_VERSION_KEY in keys:
            version = self.number(keys[ASSIGNMENT_VERSION_KEY], "the format version", integer=True)
            if version is not None and version != 1:
                self.error(keys[ASSIGNMENT_VERSION_KEY], "this labsim reads assignment format 1")
        world, world_file = self._world(keys.get("world"))
        robots = self._robots(keys.get("robots"))
        params = self._params(keys["params"]) if "params" in keys else {}
        measure = self._measure(keys["measure"], set(params)) if "measure" in keys else ()
        declared = {str(k.value) for k, _ in self.entries(keys["measure"], "measure") or []} \
            if "measure" in keys and isinstance(keys["measure"], MappingNode) else set()  # a wrong one said so
        criteria = self._criteria(keys["criteria"], {m.name for m in measure} | declared if "measure" in keys
                                  else None) if "criteria" in keys else ()
        metrics = self._names(keys["metrics"], "metrics") if "metrics" in keys else ()
        # the student's file defines the metrics named, and those of criteria on its own metrics
        metrics = tuple(dict.fromkeys([*metrics, *(c.name for c in criteria
                                                   if not c.builtin and (c.student or "measure" not in keys))]))
        seeds = self._seeds(keys["seeds"]) if "seeds" in keys else (1,)
        timeout = self._timeout(keys["timeout_s"]) if "timeout_s" in keys else DEFAULT_TIMEOUT_S
        gate_score = self._gate_score(keys["gate_score"]) if "gate_score" in keys else 0.0
        budgets = self._budgets(keys["budgets"]) if "budgets" in keys else DEFAULT_BUDGETS
        title = self.string(keys["title"], "title") if "title" in keys else None
        reference = self._reference(keys["reference"]) if "reference" in keys else None
        if self.report.errors:
            return None
        return Assignment(self.doc.path, hashlib.sha256(self.doc.text.encode()).hexdigest(),
                          title or Path(self.doc.path).stem, world, robots, params, metrics, seeds,
                          timeout or DEFAULT_TIMEOUT_S, budgets, criteria, reference, measure, gate_score,
                          world_file, _sha256_of(world_file))

    def _world(self, node: Node | None) -> tuple[str | None, str | None]:
        """The world's name and its file: a built-in world, a world file's path (relative to the
        assignment), or the name of a world file beside the assignment (its ``name:``)."""
        if node is None:
            return None, None
        name = self.name(node, "world")
        if name in (None, ANY):
            return None, None
        folder = Path(self.doc.path).parent
        beside = _world_named(name, folder)
        ref = WorldRef(beside) if beside is not None else find_world(name, folder)
        if ref.path is None and ref.refused:
            self.error(node, f"world file '{name}' lies outside the assignment's folder: the grader reads a "
                             "built-in world or a world file beside the assignment (docs/grading.md)")
            return None, None
        if ref.path is None:
            self.error(node, ref.problem, ref.notes)
            return None, None
        report = Report()
        world = load_world(ref.path, report)
        if world is None:
            first = report.errors[0].message if report.errors else "it does not read"
            self.error(node, f"world '{name}' is no world labsim can load: {first}")
            return None, None
        return name, str(ref.path)

    def _robots(self, node: Node | None) -> int | None:
        if node is None or (isinstance(node, ScalarNode) and node.value == ANY):
            return None
        count = self.number(node, "robots (a whole number, or 'any')", integer=True)
        if count is not None and not 0 <= count <= 1000:
            self.error(node, "robots is a whole number from 0 to 1000, or 'any'")
            return None
        return None if count is None else int(count)

    def _params(self, node: Node) -> dict[str, str]:
        out: dict[str, str] = {}
        for key, value in self.entries(node, "params") or []:
            if not isinstance(value, ScalarNode) or isinstance(scalar_value(value), str) or value.value == "":
                self.error(value, f"param '{key.value}' takes the value the grader sets: a number, or true or false")
                continue
            number = scalar_value(value)
            if isinstance(number, (int, float)) and not isinstance(number, bool) and not (
                    math.isfinite(number) and abs(number) <= MAX_PARAM):
                self.error(value, f"param '{key.value}' is a finite number from -2**53 to 2**53, not {value.value}")
                continue
            out[str(key.value)] = str(value.value)
        return out

    def _timeout(self, node: Node) -> float | None:
        value = self.positive(node, "timeout_s")
        if value is not None and value > MAX_TIMEOUT_S:
            self.error(node, f"timeout_s is the wall time a run may take, at most {MAX_TIMEOUT_S:g} s (an hour)")
            return None
        return value

    def _gate_score(self, node: Node) -> float:
        value = self.number(node, "gate_score")
        if value is not None and not 0 <= value <= 100:
            self.error(node, "gate_score is the score (0 to 100) of a student who fails a required criterion")
            return 0.0
        return value or 0.0

    def _measure(self, node: Node, params: set[str]) -> tuple[MetricDecl, ...]:
        """The metrics the grader measures, in the behaviour language's metric syntax; each may
        read only what a student's file cannot write (``MEASURE_VARIABLES``, the sensors and
        pose, the grader's params, the world's channels)."""
        out = []
        readable = measurable_names() | params
        for key, value in self.entries(node, "measure") or []:
            name = str(key.value)
            if not name.isidentifier() or not name.isascii():
                self.error(key, f"'{name}' is not a valid metric name: use letters, digits and '_', starting with a "
                                "letter")
                continue
            if name in BUILTINS:
                self.error(key, f"'{name}' is the name of a built-in criterion; choose another name for the metric")
                continue
            better: Better | None = None
            if isinstance(value, MappingNode):
                fields = self.fields(value, ("value", "better"), f"measured metric '{name}'")
                if fields is None or "value" not in fields:
                    self.error(key, f"measured metric '{name}' needs 'value:', the aggregate over the run")
                    continue
                if "better" in fields:
                    word = scalar_value(fields["better"]) if isinstance(fields["better"], ScalarNode) else None
                    if word not in ("higher", "lower"):
                        self.error(fields["better"], f"'better' of metric '{name}' is higher or lower")
                        continue
                    better = Better(word)
                value = fields["value"]
            if not isinstance(value, ScalarNode) or not isinstance(scalar_value(value), str):
                self.error(value, f"measured metric '{name}' is an aggregate over the run written as text, e.g. "
                                  "count(collided)")
                continue
            text = self.doc.text_of(value)
            try:
                tree = parse_expr(text.value)
            except ParseError as e:
                self.error(TextSpan(text, e.start, e.end), e.message, e.notes)
                continue
            if not (isinstance(tree, dsl_ast.Call) and tree.func in AGGREGATES):
                self.error(TextSpan(text, *tree.span), f"measured metric '{name}' must be an aggregate over the run: "
                                                        + ", ".join(f"{a}(...)" for a in AGGREGATES))
                continue
            bad = unreadable(tree, readable)
            for what, span in bad:
                why = ("a measured metric has no lists, and a group's size is known as written" if what == LEN_WORDS
                       else "a measured metric reads only what the student's file cannot write")
                self.error(TextSpan(text, *span), f"measured metric '{name}' reads {what}; {why}",
                           notes=("it may read the sensors, the pose (x, y, heading), collided, forward_speed, "
                                  "the wheel commands (wheel_left, wheel_right), time, tick, dt and the grader's "
                                  "params",))
            if not bad:
                out.append(MetricDecl(name, Parsed(tree, text), key, better, grader=True))
                self._aggregates[name] = tree.func
        return tuple(out)

    def _names(self, node: Node, what: str) -> tuple[str, ...]:
        out = []
        for item in self.items(node, what) or []:
            name = self.name(item, f"an item of '{what}'")
            if name is not None:
                out.append(name)
        return tuple(out)

    def _seeds(self, node: Node) -> tuple[int, ...]:
        if not isinstance(node, SequenceNode):  # one message for one mistake (seeds: 1-3)
            self.error(node, f"seeds is a list of 1 to {MAX_SEEDS} seeds, e.g. [1, 2, 3]")
            return (1,)
        items = list(node.value)
        if not items or len(items) > MAX_SEEDS:
            self.error(node, f"seeds is a list of 1 to {MAX_SEEDS} seeds, e.g. [1, 2, 3]")
            return (1,)
        out = []
        for item in items:
            seed = self.number(item, "a seed", integer=True)
            if seed is not None and not 0 <= seed <= WHOLE_LIMIT:
                self.error(item, f"a seed is a whole number from 0 to 2**53 ({WHOLE_LIMIT}), as labsim run --seed "
                                 "takes it")
            elif seed is not None:
                out.append(int(seed))
        if len(set(out)) != len(out):
            self.error(node, "each seed once: the same seed gives the same run")
        return tuple(out) or (1,)

    def _budgets(self, node: Node) -> Budgets:
        out = DEFAULT_BUDGETS
        for key, value in self.entries(node, "budgets") or []:
            changed, problems = out.parse([f"{key.value}={getattr(value, 'value', '')}"])
            for _, message in problems:
                self.error(key if str(key.value) not in Budgets.names() else value,
                           message.replace("give NAME=VALUE with NAME", "a budget's name is"))
            out = changed
        return out

    def _reference(self, node: Node) -> str | None:
        name = self.name(node, "reference")
        if name is None:
            return None
        path = Path(self.doc.path).parent / name
        if not path.is_file():
            self.error(node, f"no reference behaviour '{name}' (looked for {path})"
                             + did_you_mean(name, [p.name for p in path.parent.glob("*.y*ml")
                                                   if p.name != Path(self.doc.path).name and p.is_file()
                                                   and file_kind(p) == "behaviour"] if path.parent.is_dir() else []))
            return None
        return str(path)

    def _criteria(self, node: Node, measured: set[str] | None) -> tuple[Criterion, ...]:
        out = []
        for key, value in self.entries(node, "criteria") or []:
            found = self._criterion(key, value, measured)
            if found is not None:
                out.append(found)
        if isinstance(node, MappingNode) and not out and not self.report.errors:
            self.error(node, "give at least one criterion")
        return tuple(out)

    def _criterion(self, key: ScalarNode, node: Node, measured: set[str] | None) -> Criterion | None:
        """One criterion; ``measured``: the names under ``measure:`` (None: the assignment has none,
        and its criteria read the student's metrics, as before ``measure:`` was)."""
        name = str(key.value)
        fields = self.fields(node, CRITERION_KEYS, f"criterion '{name}'")
        if fields is None:
            return None
        weight = self.positive(fields["weight"], "weight") if "weight" in fields else 1.0
        required = self.flag(fields["required"], "required") if "required" in fields else False
        student = False
        if "from" in fields:
            student = scalar_value(fields["from"]) == STUDENT if isinstance(fields["from"], ScalarNode) else False
            if not student:
                self.error(fields["from"], "from: student is the one source a criterion names: a metric the "
                                           "student's file defines")
        if name in BUILTINS:
            return self._builtin(key, name, fields, weight or 1.0, required)
        if measured is not None and not student and name not in measured:
            self.error(key, f"criterion '{name}' names no measured metric{did_you_mean(name, measured)}",
                       notes=("define it under measure:, or write from: student for a metric the student's file "
                              "defines (the page then says the student defined it)",))
            return None
        if not name.isidentifier():
            self.error(key, f"'{name}' is neither a metric's name nor a built-in criterion"
                            f"{did_you_mean(name, BUILTINS)}", notes=(f"built-ins: {', '.join(BUILTINS)}",))
            return None
        given = [k for k in ("at_least", "at_most", "score") if k in fields]
        if not given and did_you_mean(name, BUILTINS):  # a built-in misspelt, not a metric
            self.error(key, f"unknown built-in criterion '{name}'{did_you_mean(name, BUILTINS)}",
                       notes=(f"built-ins: {', '.join(BUILTINS)}",))
            return None
        if len(given) != 1:
            self.error(node, f"criterion '{name}' takes one of at_least, at_most or score: [worst, best]")
            return None
        if given[0] == "score":
            pair = self.pair(fields["score"], "score")
            if pair is not None and pair[0] == pair[1]:
                self.error(fields["score"], "score: [worst, best] needs two different values")
                return None
            return None if pair is None else Criterion(name, weight or 1.0, worst=pair[0], best=pair[1],
                                                       required=required, student=student)
        limit = self.number(fields[given[0]], given[0])
        if limit is None:
            return None
        aggregate = self._aggregates.get(name, "") if not student else ""
        if aggregate in ("count", "duration") and limit < 0:  # a count, a duration is never below 0
            what = "a count" if aggregate == "count" else "a duration"
            self.error(fields[given[0]], f"'{name}' is {what}, never below 0: {given[0]}: {limit:g} "
                                         + ("passes every run" if given[0] == "at_least" else "fails every run"))
            return None
        return Criterion(name, weight or 1.0, **{given[0]: limit}, required=required, student=student)

    def _builtin(self, key: ScalarNode, name: str, fields: dict[str, Node], weight: float,
                 required: bool) -> Criterion | None:
        """A built-in criterion (``no_faults``, ``moved: {at_least: METRES}``, ...)."""
        allowed = {"weight", "required", *(("at_least",) if name == MOVED else ())}
        for extra in set(fields) - allowed:
            self.error(fields[extra], f"the built-in criterion '{name}' takes "
                                      f"{'at_least (metres), ' if name == MOVED else ''}a weight and required "
                                      f"only, not '{extra}'")
        if name != MOVED:
            return Criterion(name, weight, required=required)
        if "at_least" not in fields:
            self.error(key, "moved takes at_least: METRES, the distance each robot must drive")
            return None
        metres = self.number(fields["at_least"], "at_least")
        if metres is not None and metres < 0:
            self.error(fields["at_least"], "moved: at_least is a distance, 0 or more metres")
            return None
        return None if metres is None else Criterion(name, weight, at_least=metres, required=required)

    def flag(self, node: Node, what: str) -> bool:
        value = scalar_value(node) if isinstance(node, ScalarNode) else None
        if not isinstance(value, bool):
            self.error(node, f"{what} is true or false")
            return False
        return value


def _world_named(name: str, folder: Path) -> Path | None:
    """A world file beside the assignment whose ``name:`` is ``name`` (a world named so, not a path)."""
    if name in builtin_worlds() or name.endswith(YAML_SUFFIXES) or "/" in name:
        return None
    for p in sorted(folder.glob("*.y*ml")):
        if p.suffix in YAML_SUFFIXES and p.is_file() and not p.is_symlink() and file_kind(p) == "world":
            world = load_world(p, Report())
            if world is not None and world.name == name:
                return p
    return None


def _sha256_of(path: str | None) -> str:
    if path is None:
        return ""
    try:
        return hashlib.sha256(read_input(path, "world")).hexdigest()
    except LabsimError:
        return ""


_BUDGET_HINT = re.compile(r"--budget (\w+)=([\w.,]+)")


def budget_words(text: str) -> str:
    """A budget's message as a grader's: ``labsim grade`` has no ``--budget``; the assignment's
    ``budgets:`` raise one."""
    return _BUDGET_HINT.sub(lambda m: f"the assignment's budgets: {{{m.group(1)}: {m.group(2).rstrip('.,')}}}", text)
