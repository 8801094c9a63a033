"""A condition to watch a compiled run by: a live view's breakpoint (``labsim view --break``).

Outside the file, after it compiled: ``compile_watch`` parses one expression of the language
(``labsim.dsl.syntax.parse``) and checks it as the stop condition is checked (``ExprChecker.expect``,
a boolean), against the names the compiled ``Program`` has: the sensors its behaviour reads (a
joint's, a body's and a force sensor's fields too), its signals (groups too), its functions,
parameters, sliders, states, ``time``, ``tick``, ``dt`` and ``state``. Its
diagnostics are the file's kind, with the line and column in the condition's own text
(``--break:1:8: unknown name 'sonr5' (did you mean 'sonar5'?)``). A ``Watch`` is evaluated
once a tick with the reference evaluator (``labsim.dsl.analysis.evaluate``), which sees one tick:
functions that remember earlier ticks (``prev``, ``rising``, ...) are refused when checked,
wherever they are (inside a group too). The same compiled condition stops ``labsim run --break``
(``labsim.runtime.breakpoint``), which prints the values it read (``Watch.values``).
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import yaml
from yaml.nodes import ScalarNode

from labsim.backends.scene.models import Kind
from labsim.dsl.analysis.evaluate import Function, Members, Rows, Unsupported, evaluate
from labsim.dsl.analysis.infer import ExprChecker
from labsim.dsl.analysis.messages import heard_slot
from labsim.dsl.emit.program import FunctionText, Program
from labsim.dsl.library.builtins import CONSTANTS, FIELDS, FUNCTIONS, READ_BACK, Type
from labsim.dsl.library.support import STATE
from labsim.dsl.syntax import ast
from labsim.dsl.syntax.ast import walk
from labsim.dsl.syntax.parse import ParseError, parse_expr
from labsim.dsl.syntax.read import FunctionDecl, Parsed, later_format
from labsim.foundation.diagnostics import Diagnostic, LabsimError, Report, did_you_mean, listed, quoted
from labsim.foundation.source import Document, Text

MAX_WATCH_CHARS = 500  # a condition typed in a page or on the command line; the rest is a mistake
_KIND_TYPES = {Kind.DISTANCE: Type.NUMBER, Kind.NUMBER: Type.NUMBER, Kind.BOOL: Type.BOOL, Kind.CONTACT: Type.BOOL,
               Kind.REFLECTANCE: Type.NUMBER, Kind.JOINT: Type.JOINT, Kind.FORCE: Type.FORCE, Kind.BODY: Type.BODY}
_FIELD = {name: index for fields in FIELDS.values() for name, (index, _) in fields.items()}
_VARIABLES = {"time": Type.NUMBER, "tick": Type.NUMBER, "dt": Type.NUMBER, "state": Type.STATE}


@dataclass(frozen=True)
class Watch:
    """A checked condition: its text, its tree, and where each name it reads comes from."""

    text: str
    node: ast.Expr
    channels: tuple[tuple[str, int], ...]  # name -> index into a robot's readings
    slots: tuple[tuple[str, int], ...]  # signals and sliders: name -> slot
    constants: Mapping[str, object]  # parameters, states (their indices), dt
    reads: tuple[str, ...] = ()  # the names it reads, in the order written (constants left out)
    states: tuple[str, ...] = ()  # the program's states, by index: a state's value is shown by its name
    # the group signals it reads (and those they name), in the file's order: their members' slots,
    # or None and the expression that names them
    groups: tuple[tuple[str, tuple[int, ...] | None, ast.Expr], ...] = ()
    functions: Mapping[str, Function] = field(default_factory=dict)  # the file's own

    def names(self, tick: int, dt_s: float, readings: Sequence[object], slots: Sequence[object]) -> dict[str, object]:
        """Every name's value on a tick, from the robot's readings and slots."""
        names: dict[str, object] = dict(self.constants)
        names["time"], names["tick"], names["state"] = tick * dt_s, float(tick), slots[STATE]
        for name, i in self.channels:
            names[name] = readings[i]
        for name, i in self.slots:
            names[name] = slots[i]
        for name, members, node in self.groups:
            if members is not None:
                names[name] = Members(slots[i] for i in members)
            else:  # sonar1..sonar8: the values it names, as its uses read them
                names[name], _ = evaluate(node, names, constants=self.constants)
        return names

    def holds(self, tick: int, dt_s: float, readings: Sequence[object], slots: Sequence[object]) -> bool:
        """Whether the condition holds on a tick, from the robot's readings and slots."""
        try:
            value, _ = evaluate(self.node, self.names(tick, dt_s, readings, slots), constants=self.constants,
                                functions=self.functions)
        except Unsupported:  # what the checks let through and one tick cannot answer: never holds
            return False
        return bool(value)

    def values(self, tick: int, dt_s: float, readings: Sequence[object], slots: Sequence[object]
               ) -> list[tuple[str, object]]:
        """The values of the names it reads on a tick, in the order written."""
        names = self.names(tick, dt_s, readings, slots)
        out: list[tuple[str, object]] = []
        for n in self.reads:
            if n == "state" and self.states:
                out.append((n, self.states[int(names[n])]))  # type: ignore[call-overload]
            elif n in names and n not in self.states:  # a state's name is a constant: not shown
                out.append((n, names[n]))
            elif "." in n and n.split(".")[0] in names:  # Load.x: a field of a reading
                record, attr = n.split(".", 1)
                out.append((n, names[record][_FIELD[attr]]))  # type: ignore[index]
        return out


def compile_watch(program: Program, text: str, where: str = "--break") -> Watch:
    """The condition ``text`` checked against the program's names; LabsimError says what is
    wrong, at ``where``:1:column."""
    if len(text) > MAX_WATCH_CHARS:
        raise LabsimError([Diagnostic(where, f"a condition of at most {MAX_WATCH_CHARS} characters, "
                                             f"not {len(text):,}")])
    doc = Document(where, text, None)
    node = ScalarNode("tag:yaml.org,2002:str", text, yaml.Mark(where, 0, 0, 0, text, 0),
                      yaml.Mark(where, len(text), 0, len(text), text, len(text)))
    parsed_text = doc.text_of(node)
    report = Report()
    try:
        e = parse_expr(text)
    except ParseError as p:
        notes = p.notes or (f"a breakpoint is one condition of the language, as in {where} 'sonar5 < 0.5'",)
        report.add(parsed_text.diagnostic(p.start, p.end, p.message, notes=notes))
        raise LabsimError(report.diagnostics) from None
    checker = ExprChecker(doc, report)
    checker.version = program.version
    own = {name for group in program.robots for name, _ in group.params}  # a robot's own: known while running
    checker.constants = {**CONSTANTS, "dt": program.dt_s, **{k: v for k, v in program.params.items() if k not in own}}
    images, groups, unseen = _declare(program, checker)
    if program.version < 1.3:  # wheel_left, start_x, ...: as the file itself would be told
        checker.unavailable.update({name: later_format(f"'{name}'", 1.3) for name in READ_BACK})
    _unseen(e, parsed_text, program, checker, images, unseen)
    checker.expect(Parsed(e, parsed_text), e, Type.BOOL, "a breakpoint's condition")
    _heard(program, checker, parsed_text)
    for call in _calls(e):
        if call.func in FUNCTIONS and FUNCTIONS[call.func].stateful:
            report.add(parsed_text.diagnostic(call.span[0], call.span[1],
                                              f"{call.func}() remembers earlier ticks; a breakpoint sees one "
                                              "tick at a time", notes=("make it a signal in the file (let:) "
                                                                       "and watch the signal",)))
    report.raise_if_errors()
    reads = _Reads(set(checker.user_functions))
    reads.visit(e)
    wanted = set(reads.names)
    kept: list[tuple[str, tuple[int, ...] | None, ast.Expr]] = []
    for name, members, written in reversed(groups):  # a group it reads, and the groups that one names
        if name in wanted:
            kept.insert(0, (name, members, written))
            wanted |= {n.id for n in walk(written) if isinstance(n, ast.Name)} if members is None else set()
    return Watch(  # every name it may read (a name inside a group is read too)
        text=text, node=e,
        channels=tuple((n, i) for i, n in enumerate(program.channels) if program.channel_kinds.get(n) in _KIND_TYPES),
        slots=tuple((n, program.slot_of[n]) for n in (*program.single_signals, *program.slider_names, *READ_BACK,
                                                      *map(heard_slot, program.said)) if n in program.slot_of),
        constants={**{n: float(v) for n, v in program.params.items() if isinstance(v, (int, float))},
                   **{n: Rows(Members(row) for row in v) if v and isinstance(v[0], tuple) else Members(v)
                      for n, v in program.lists.items()},
                   **{n: float(i) for i, n in enumerate(program.state_names)}, "dt": program.dt_s},
        reads=tuple(dict.fromkeys(n for n in reads.names if n not in CONSTANTS)), states=tuple(program.state_names),
        groups=tuple(kept),
        functions={name: (d.params, d.body.node) for name, d in checker.user_functions.items()})


def _declare(program: Program, checker: ExprChecker) -> tuple[set[str], list[tuple[str, tuple[int, ...] | None,
                                                                                 ast.Expr]], dict[str, str]]:
    """Declare to the checker every name of the program a breakpoint reads; return the images it
    does not read, the group signals it does and those it cannot (see ``_groups``)."""
    for name, kind in program.channel_kinds.items():
        if kind in _KIND_TYPES:
            checker.declare(name, _KIND_TYPES[kind], "sensor")
    single = set(program.single_signals)
    # an image is freed after the tick that computed it, and a breakpoint shows numbers: not read
    images = {n for n, k in program.channel_kinds.items() if k is Kind.IMAGE and n in program.channels}
    for name, t in program.signal_types.items():
        if t is Type.IMAGE:
            images.add(name)
        elif name in single:
            checker.declare(name, t, "signal")
    for name in program.params:
        checker.declare(name, Type.NUMBER, "parameter")
    checker.lists = dict(program.lists)
    for name, value in program.lists.items():  # format 1.3: a list of rows, or of numbers (a group)
        checker.declare(name, Type.LIST if value and isinstance(value[0], tuple) else Type.NUMBERS, "list parameter")
        if not (value and isinstance(value[0], tuple)):
            checker.group_sizes[name] = len(value)
    for name in READ_BACK:  # read back where the file reads it: it has a slot
        if name in program.slot_of:
            checker.declare(name, Type.NUMBER, "built-in variable")
    for name in program.slider_names:
        checker.declare(name, Type.NUMBER, "slider")
    for name in program.state_names:
        checker.declare(name, Type.STATE, "state")
    for name, t in _VARIABLES.items():
        checker.declare(name, t, "built-in variable")
    for name in CONSTANTS:
        checker.declare(name, Type.NUMBER, "constant")
    checker.metric_names = set(program.metric_names)
    groups, unseen = _groups(program, checker)
    functions = {f.name: _function(program, f) for f in program.functions}
    checker.user_functions = {name: d for name, d in functions.items() if d is not None}
    return images, groups, unseen


def _unseen(e: ast.Expr, parsed_text: Text, program: Program, checker: ExprChecker, images: set[str],
            unseen: dict[str, str]) -> None:
    """Say why a name the program has is not one a breakpoint reads: a sensor the behaviour does
    not read (a range of them in one message), an image, a group signal naming what it cannot see."""
    report, text = checker.report, parsed_text.value
    unread = {name for m in program.models.values() for name in m.channels()} - set(program.channels)
    said: set[int] = set()  # the members of a range, said in one message at the range
    for ranged in ast.walk(e):
        if isinstance(ranged, ast.Group) and ranged.ranged:
            names = [m.id for m in ranged.members if isinstance(m, ast.Name) and m.id in unread]
            if not names:
                continue
            said |= {id(m) for m in ranged.members}
            checker.poisoned |= set(names)
            report.add(parsed_text.diagnostic(ranged.span[0], ranged.span[1], f"{text[ranged.span[0]:ranged.span[1]]} "
                                              f"names {', '.join(names)}, which this behaviour does not read: a "
                                              "breakpoint sees what the behaviour reads",
                                              notes=(f"read them in a signal of the file (e.g. 'let: seen: "
                                                     f"{text[ranged.span[0]:ranged.span[1]]}') and watch the "
                                                     "signal",)))
    robots = {g.name for g in program.robots}
    if program.version >= 1.3 and "heard" not in checker.user_functions:  # heard(x): a channel, not a name read
        said |= {id(c.args[0]) for c in ast.walk(e) if isinstance(c, ast.Call) and c.func == "heard" and c.args}
    for read in ast.walk(e):
        if id(read) in said:
            continue
        base = read.value.value if isinstance(read, ast.Attribute) and isinstance(read.value, ast.Index) else \
            read.value if isinstance(read, ast.Attribute) else None
        if isinstance(base, ast.Name) and base.id in robots and base.id not in checker.types:  # leader.x (1.3)
            written = text[read.span[0]:read.span[1]]
            report.add(parsed_text.diagnostic(read.span[0], read.span[1], f"a breakpoint sees one robot's own values, "
                                              f"not {written}", notes=(f"read it in a signal of the file (e.g. 'let: "
                                                                       f"other: {written}') and watch the signal",)))
            checker.poisoned.add(base.id)
            continue
        if isinstance(read, ast.Name) and read.id in images and read.id not in checker.types:
            report.add(parsed_text.diagnostic(read.span[0], read.span[1], f"'{read.id}' is an image: a breakpoint "
                                              "reads numbers and booleans",
                                              notes=(f"make a number of it a signal of the file (e.g. 'let: seen: "
                                                     f"mean({read.id})') and watch the signal",)))
            checker.poisoned.add(read.id)
            continue
        if isinstance(read, ast.Name) and read.id in unread and read.id not in checker.types:
            report.add(parsed_text.diagnostic(read.span[0], read.span[1], f"'{read.id}' is a sensor this behaviour "
                                              "does not read: a breakpoint sees what the behaviour reads",
                                              notes=(f"read it in a signal of the file (e.g. 'let: seen: {read.id}') "
                                                     "and watch the signal",)))
            checker.poisoned.add(read.id)
        elif isinstance(read, ast.Name) and read.id in (*READ_BACK, "index") and read.id not in checker.types:
            report.add(_read_back_unseen(read, parsed_text, program.version))
            checker.poisoned.add(read.id)
        elif isinstance(read, ast.Name) and read.id in unseen and read.id not in checker.types:
            report.add(parsed_text.diagnostic(read.span[0], read.span[1], f"'{read.id}' is a group signal a "
                                              f"breakpoint cannot read: it names '{unseen[read.id]}', which a "
                                              "breakpoint does not see", notes=("watch its other members one by "
                                                                                "one",)))
            checker.poisoned.add(read.id)


def _read_back_unseen(read: ast.Name, parsed_text: Text, version: float) -> Diagnostic:
    """A read-back name (``wheel_left``, ``start_x``) the behaviour does not read: it has no slot to watch;
    nor has ``index``, a robot's place in its group."""
    if read.id == "index":
        return parsed_text.diagnostic(read.span[0], read.span[1], "'index' (the robot's place in its group) is not "
                                      "readable by a breakpoint", notes=("read it in a signal of the file (e.g. "
                                                                         "'let: place: index') and watch the signal",))
    if version < 1.3:
        return parsed_text.diagnostic(read.span[0], read.span[1], later_format(f"'{read.id}'", 1.3))
    what = "wheel command" if read.id.startswith("wheel") else "start pose"
    return parsed_text.diagnostic(read.span[0], read.span[1], f"'{read.id}' (the robot's {what}) is read back only "
                                  "where the behaviour reads it: a breakpoint sees what the behaviour reads",
                                  notes=(f"read it in a signal of the file (e.g. 'let: seen: {read.id}') and watch "
                                         "the signal",))


def _heard(program: Program, checker: ExprChecker, parsed_text: Text) -> None:
    """A breakpoint reads ``heard(channel)`` as the file's signals do, from the robot's inbox of the
    tick: a channel the file hears has a slot holding it; any other channel is refused."""
    for channel, places in checker.heard.items():
        if heard_slot(channel) in program.slot_of:
            continue
        for name, _ in places:
            if channel in program.said:
                message = f"a breakpoint reads what the file hears, and the file never reads heard({channel})"
                notes: tuple[str, ...] = (f"read it in a signal of the file (e.g. 'let: got: heard({channel})') "
                                          "and watch the signal",)
            else:
                message = f"nothing says on channel {quoted(channel)}{did_you_mean(channel, list(program.said))}"
                notes = ("channels said in this file: " + listed(program.said) if program.said else
                         "the file says nothing: a channel is said by an action of a rule, as in say(target, x)",)
            checker.report.add(parsed_text.diagnostic(name.span[0], name.span[1], message, notes=notes))


def _groups(program: Program, checker: ExprChecker) -> tuple[list[tuple[str, tuple[int, ...] | None, ast.Expr]],
                                                               dict[str, str]]:
    """The group signals a breakpoint may read, declared to the checker; and those it may not, each
    with the name it cannot see: a group without slots of its own that names a value without one
    either (``[index, 1]``: a robot's place in its group)."""
    out: list[tuple[str, tuple[int, ...] | None, ast.Expr]] = []
    unseen: dict[str, str] = {}
    for g in program.group_signals:
        try:
            node = parse_expr(g.expr)
        except ParseError:  # it compiled: not reached
            continue
        hidden = [n.id for n in walk(node) if isinstance(n, ast.Name) and n.id not in checker.types]
        if g.slots is None and hidden:
            unseen[g.name] = hidden[0]
            continue
        checker.declare(g.name, program.signal_types[g.name], "signal")
        checker.group_sizes[g.name] = g.size
        out.append((g.name, g.slots, node))
    return out, unseen


def _function(program: Program, f: FunctionText) -> FunctionDecl | None:
    """A function of the file's own, its body at its line and column of the file, for the checker."""
    try:
        body = parse_expr(f.body)
    except ParseError:  # it compiled: not reached
        return None
    line = f.source_line if f.source_line[f.col - 1:].startswith(f.body) else " " * (f.col - 1) + f.body
    text = "\n" * (f.line - 1) + line[:f.col - 1] + f.body
    start, end = len(text) - len(f.body), len(text)
    node = ScalarNode("tag:yaml.org,2002:str", f.body,
                      yaml.Mark(program.path, start, f.line - 1, f.col - 1, text, start),
                      yaml.Mark(program.path, end, f.line - 1, f.col - 1 + len(f.body), text, end))
    return FunctionDecl(f.name, f.params, Parsed(body, Document(program.path, text, None).text_of(node)), node)


class _Reads(ast.Visitor[None]):
    """The names a condition reads, in the order written; the breakpoint prints their values."""

    def __init__(self, own: set[str]) -> None:
        self.names: list[str] = []
        self.own = own  # the file's own functions: a 1.2 file's heard() is its own

    def visit_Name(self, e: ast.Name) -> None:
        self.names.append(e.id)

    def visit_Call(self, e: ast.Call) -> None:
        if e.func == "heard" and e.func not in self.own and e.args and isinstance(e.args[0], ast.Name):
            # a channel is no name: what is heard on it is read
            self.names.append(heard_slot(e.args[0].id))
            for a in e.args[1:]:
                self.visit(a)
            return
        self.generic_visit(e)  # detected(sonar5) reads sonar5, as its argument

    def visit_Attribute(self, e: ast.Attribute) -> None:
        if isinstance(e.value, ast.Name):
            self.names.append(f"{e.value.id}.{e.attr}")  # Load.x: the field is shown, not the record
        else:
            self.visit(e.value)

    # every other node reads what its parts read
    generic = frozenset(set(ast.node_classes()) - {ast.Name, ast.Call, ast.Attribute})


def _calls(e: ast.Expr) -> list[ast.Call]:
    return [x for x in walk(e) if isinstance(x, ast.Call)]
