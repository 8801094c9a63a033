"""Expression types: the half of the checker that resolves names and types expressions.

``labsim.dsl.analysis.check`` declares what is in scope (sensors, parameters, ``let`` signals, states,
sliders, built-ins) and asks ``ExprChecker.infer`` and ``ExprChecker.expect`` for the type of
each expression of the file. Each unknown name, each operand of the wrong type and each wrong
call is reported here, with a did-you-mean where one helps; an expression that has no type
gives None, and its uses say nothing more.

Over 500 lines: one method per kind of node and one per check of an expression, all reading the
names in scope; the words of the messages several checks share are in ``labsim.dsl.analysis.wording``.
"""
from __future__ import annotations

from yaml.nodes import Node

from labsim.dsl.analysis.fold import fold
from labsim.dsl.analysis.functions import RANDOM, Expansion, body_name, body_note, check_call, known_value
from labsim.dsl.analysis.messages import HEARD, SAY, heard_type
from labsim.dsl.analysis.peers import PEER_VALUES, Received, peer_type
from labsim.dsl.analysis.wording import (
    FUNCTION_NAMES,
    arity_message,
    function_notes,
    literal,
    range_text,
    reduction_arity,
    shown_setting,
    text_note,
    unknown_name_notes,
)
from labsim.dsl.library.builtins import (
    ACTIONS,
    AGGREGATES,
    DETECTED,
    FIELDS,
    FUNCTIONS,
    MEANT,
    READ_BACK,
    REDUCTIONS,
    STATEFUL,
    Function,
    Type,
)
from labsim.dsl.syntax import ast
from labsim.dsl.syntax.lists import ListValue
from labsim.dsl.syntax.read import VERSIONS, FunctionDecl, Parsed, later_format
from labsim.foundation.diagnostics import Diagnostic, Report, did_you_mean, quoted
from labsim.foundation.numbers import WHOLE_LIMIT, place_text
from labsim.foundation.source import Document, Place, Text

# Operations a file's groups are written out to, at most (a member of each group-typed node, and
# each node of a value paired with every member, once per member): a few hundred thousand lines
# of Python take the compiler seconds and gigabytes.
MAX_WRITTEN_OUT = 200_000
# What each member of a built-in with memory given a group (format 1.3) counts besides: its memory is a
# guard of its own, made for every robot and compiled as a call (a lidar's 1000 beams through total()
# are 1000 memories)
MEMORY_WEIGHT = 4


class ExprChecker(ast.Visitor["Type | None"]):
    """The names in scope, their types, and the checks of expressions against them: ``infer``
    visits each node with the method for its kind (``visit_Binary``, ...)."""

    def __init__(self, doc: Document, report: Report) -> None:
        self.doc = doc
        self.report = report
        self.types: dict[str, Type] = {}  # every name in scope
        self.kinds: dict[str, str] = {}  # name -> what it is, for messages
        self.used: set[str] = set()
        self.later: dict[str, Node] = {}  # lets not yet defined while checking one, for messages
        self.settings: dict[str, str] = {}  # parameters set on the command line -> "--set NAME=VALUE"
        self.node_types: dict[int, Type] = {}  # id(AST node) -> its type
        self.distance: set[str] = set()  # distance sensors, for detected()
        self.poisoned: set[str] = set()  # names whose definition failed: no follow-on errors
        self.world_failed = False  # names the world would have given are not reported unknown
        self.metric_names: set[str] = set()  # the file's metrics: not names an expression can read
        self.sizes: dict[int, int] = {}  # id(AST node) of a group -> its members
        self.group_sizes: dict[str, int] = {}  # a signal that is a group -> its members
        # user functions (labsim.dsl.analysis.functions): the callable ones, the bodies being typed (the
        # definition, its parameters' types and sizes, the call and its text), each call's typed copy
        self.user_functions: dict[str, FunctionDecl] = {}
        self.scopes: list[tuple[FunctionDecl, dict[str, tuple[Type, int]], ast.Call | None, Text]] = []
        self.expansions: dict[int, Expansion] = {}
        self.expanded = 0  # nodes the calls expanded to so far
        self.expanded_reported = False  # past MAX_EXPANDED: said once
        self.body_errors: set[tuple[int, int, str]] = set()  # a body's problems, reported once
        self.called: set[str] = set()
        self.current_let = ""  # the signal being typed: prev() of it reads its previous tick
        self.self_prev: set[int] = set()  # id(call) of each prev(signal, initial) inside that signal
        self.self_prev_types: list[tuple[ast.Call, Type | None]] = []  # the current signal's, with their types
        self.clashed: set[str] = set()  # names two declarations share: reported once, where declared
        # values known before the run, which the code generator folds: parameters every robot
        # shares (--set included), the constants, dt; an index made of them is checked here
        self.constants: dict[str, object] = {}
        self.robot_constants: list[tuple[str, dict[str, object]]] = []  # with a robot's own parameters
        self.member_constants: list[tuple[str, dict[str, object]]] = []  # each robot's, with its index too
        self.members_written = 0  # what the groups' operators are written out to, so far (written_out)
        self.written_out_reported = False
        self.per_member_reported: set[int] = set()  # id(call) of a value paired with every member, reported
        self.unavailable: dict[str, str] = {}  # built-in names this file cannot read, and why (check.read_back)
        self.unavailable_notes: dict[str, tuple[str, ...]] = {}  # and the hint
        self.set_values: dict[str, str] = {}  # the --set NAME=VALUE of the command line, as given
        self.group_self = 0  # while a group signal reading itself from one start is read again: its size
        self.lists: dict[str, ListValue] = {}  # list parameters (format 1.3)
        self.lengths: dict[int, int] = {}  # id(call) of len(...) -> its value
        # the file's format: a built-in given a group applies member by member, and a slice, from 1.3 on;
        # a breakpoint, which has no file of its own, reads the latest
        self.version: float = VERSIONS[-1]
        # the robots another robot's name reads (group -> robots), the file's signals, and
        # what is read of the others (labsim.dsl.analysis.peers)
        self.robot_counts: dict[str, int] = {}
        self.overrides: dict[str, str] = {}  # the --set values, by name: a place made of one names it
        self.signal_names: tuple[str, ...] = ()
        self.peer_fields: dict[str, Type] = {}
        self.peer_later: list[tuple[ast.Peer, Text]] = []
        self.received: dict[str, Received] = {}  # each value read of another robot at a known place
        self.received_at: dict[int, str] = {}  # id(Peer) -> its name in ``received``
        self.said: dict[str, None] = {}  # the channels say() sends on, in the order first said
        self.heard: dict[str, list[tuple[ast.Name, Text]]] = {}  # the channels heard() reads, and where

    def error(self, place: Place, message: str, notes: tuple[str, ...] = ()) -> None:
        """Report a problem at a place of the file: a YAML node, characters of an expression's
        text (``text.at(span)``), or None for the file as a whole. Inside a function's body, a
        problem is reported once, with the call it was found through."""
        d = self.doc.diagnostic(place, message, notes=notes + body_note(self))
        if self.scopes:
            key = (d.line, d.col, d.message)
            if key in self.body_errors:
                return
            self.body_errors.add(key)
        self.report.add(d)

    def place_error(self, e: ast.Index, text: Text, message: str, notes: tuple[str, ...] = ()) -> None:
        """An error about the place ``g[k]`` of a list picks, known before the run (format 1.3): at the ``--set``
        it comes from when g or k reads a parameter set on the command line (once per setting and message), else
        at k in the file, as for a group."""
        setting = next((self.settings[n.id] for part in (e.value, e.index) for n in ast.walk(part)
                        if isinstance(n, ast.Name) and n.id in self.settings and not self.scopes), None)
        listed = isinstance(e.value, ast.Name) and e.value.id in self.lists  # a group's place stays in the file
        if setting is None or not listed:
            self.error(text.at(e.index.span), message, notes=notes)
            return
        if any((x.path, x.message) == (setting, message) for x in self.report.diagnostics):
            return
        d = self.doc.diagnostic(text.at(e.span), message)
        read = text.value[e.span[0]:e.span[1]]
        self.report.add(Diagnostic(setting, message, notes=(*notes, f"{read} reads it, on line {d.line} of {d.path}")))

    def declare(self, name: str, t: Type, kind: str) -> None:
        self.types[name] = t
        self.kinds[name] = kind

    def expect(self, parsed: Parsed, e: ast.Expr, want: Type, what: str) -> bool:
        return self.matches(parsed.text, e, self.infer(e, parsed.text), want, what)

    def matches(self, text: Text, e: ast.Expr, t: Type | None, want: Type, what: str,
                later: tuple[str, ...] = ()) -> bool:
        """Whether e, of type t (None: already reported), is what is wanted; if not, why, with a hint
        (and ``later``, what a later format would make of it)."""
        if t is None:
            return False
        if t is not want:
            if self.explained(e):
                return False
            hint: tuple[str, ...] = ()
            if want is Type.BOOL and t is Type.NUMBER:
                hint = ("compare it with something, e.g. 'sonar5 <= 0.5'",)
            elif t is Type.BOOLS:
                hint = ("a group holds one value per member: take any(...), all(...) or count(...) of it",)
            elif t is Type.NUMBERS:
                hint = ("a group holds one value per member: take min(...), max(...), mean(...), sum(...), "
                        "argmin(...) or argmax(...) of it, or one member, as in front[0]",)
            elif t is Type.TEXT:
                hint = ('text is for a log\'s fields only, as in log("turning {\'left\' if s > 0 else \'right\'}")',)
            self.error(text.at(e.span), f"{what} must be {want.a}, but this is {t.a}", notes=hint + later)
            return False
        return True

    def infer(self, e: ast.Expr, text: Text) -> Type | None:
        """The type of an expression, or None after reporting why it has none."""
        t = self._infer(e, text)
        if t is Type.LIST and not isinstance(e, ast.Name):  # wp if c else wp, a function returning wp
            self.list_by_name(e, text)
            return None
        if t is not None:
            self.node_types[id(e)] = t
            if t in (Type.NUMBERS, Type.BOOLS) and not self.written_out(e, text):
                return None
        return t

    def list_by_name(self, e: ast.Expr, text: Text) -> None:
        """A list of rows is a parameter of the file, read where it is named (format 1.3): one computed
        (chosen by 'if ... else', a function's result) is refused at the expression that computes it."""
        expansion = self.expansions.get(id(e)) if isinstance(e, ast.Call) else None
        found = [e] if expansion is None else [e, expansion.body]
        name = next((n.id for f in found for n in ast.walk(f) if isinstance(n, ast.Name) and n.id in self.lists),
                    "waypoints")
        what = "this is a list of rows" if expansion is None else f"{expansion.decl.name}() gives the list of rows"
        self.error(text.at(e.span), f"{what} '{name}', which is read only where it is named: write {name}[i] for "
                   f"a row, {name}[i][0] for a number of it, or len({name})",
                   notes=("a signal, an 'if ... else' or a function's result is a number, a boolean or a group",))

    def written_out(self, e: ast.Expr, text: Text) -> bool:
        """Count what a group-typed node is written out to (a member each, and its operands that are
        one value once per member); False, after saying so, past MAX_WRITTEN_OUT in the file."""
        n = self.size(e) if not isinstance(e, ast.Name) or e.id in self.group_sizes or self.scopes else 0
        member_wise = isinstance(e, ast.Neg | ast.Not | ast.Binary | ast.Compare | ast.BoolOp | ast.IfExp) or (
            isinstance(e, ast.Call) and id(e) not in self.expansions)  # a built-in given a group (format 1.3)
        paired = ast.children(e) if member_wise else ()
        memory = MEMORY_WEIGHT if isinstance(e, ast.Call) and e.func in STATEFUL and member_wise else 0
        self.members_written += n * (1 + memory + sum(sum(1 for _ in ast.walk(c)) for c in paired
                                                      if self.node_types.get(id(c)) not in (Type.NUMBERS, Type.BOOLS)))
        if self.members_written <= MAX_WRITTEN_OUT:
            return True
        if not self.written_out_reported:
            self.written_out_reported = True
            self.error(text.at(e.span), f"the groups of this file are written out to more than {MAX_WRITTEN_OUT:,} "
                       "operations, one per member of each (a call of a function, once per call"
                       + (f"; a function with memory, {1 + MEMORY_WEIGHT} per member)" if self.version >= 1.3 else ")"),
                       notes=("reduce a group once, in a 'let' signal, and use the signal; a function called "
                              "many times on a large group is written out for each call",))
        return False

    def _infer(self, e: ast.Expr, text: Text) -> Type | None:
        return self.visit(e, text)

    # -- each kind of node ---------------------------------------------------------------------
    def visit_Number(self, e: ast.Number, text: Text) -> Type | None:
        return Type.NUMBER

    def visit_Bool(self, e: ast.Bool, text: Text) -> Type | None:
        return Type.BOOL

    def visit_Name(self, e: ast.Name, text: Text) -> Type | None:
        return self.name(e, text)

    def visit_Text(self, e: ast.Text, text: Text) -> Type | None:
        return Type.TEXT

    def visit_Group(self, e: ast.Group, text: Text) -> Type | None:
        return self.group(e, text)

    def visit_Index(self, e: ast.Index, text: Text) -> Type | None:
        return self.index(e, text)

    def visit_Slice(self, e: ast.Slice, text: Text) -> Type | None:
        return self.slice(e, text)

    def visit_Neg(self, e: ast.Neg, text: Text) -> Type | None:
        return self.operands(e, text, "-", [e.operand], Type.NUMBER, Type.NUMBER)

    def visit_Not(self, e: ast.Not, text: Text) -> Type | None:
        return self.operands(e, text, "not", [e.operand], Type.BOOL, Type.BOOL)

    def visit_Binary(self, e: ast.Binary, text: Text) -> Type | None:
        return self.operands(e, text, e.op, [e.left, e.right], Type.NUMBER, Type.NUMBER)

    def visit_BoolOp(self, e: ast.BoolOp, text: Text) -> Type | None:
        return self.operands(e, text, e.op, list(e.values), Type.BOOL, Type.BOOL)

    def visit_Compare(self, e: ast.Compare, text: Text) -> Type | None:
        return self.compare(e, text)

    def visit_IfExp(self, e: ast.IfExp, text: Text) -> Type | None:
        c, a, b = self.infer(e.test, text), self.infer(e.body, text), self.infer(e.orelse, text)
        grouped = {c, a, b} & {Type.NUMBERS, Type.BOOLS}
        if grouped and self.version >= 1.3:
            return self.choose_members(e, text, c, a, b)
        later = (later_format("choosing member by member", 1.3),) if grouped else ()
        if not self.matches(text, e.test, c, Type.BOOL, "the condition of 'a if condition else b'", later) and later:
            return None  # one message about the groups
        if Type.NUMBERS in (a, b) or Type.BOOLS in (a, b):
            self.error(text.at(e.span), "'a if condition else b' chooses between two values, not groups: "
                       "choose between members or reductions of them", notes=later)
            return None
        if a is not None and b is not None and a is not b:
            self.error(text.at(e.span), "both sides of 'a if condition else b' must have one type, "
                       f"not {a.a} and {b.a}")
            return None
        return a if a is not None else b

    def choose_members(self, e: ast.IfExp, text: Text, c: Type | None, a: Type | None, b: Type | None) -> Type | None:
        """``front if front < 1 else 1`` (format 1.3): a group of choices, one per member, each made by
        that member's condition (or the one condition) between that member's values."""
        if c is None or a is None or b is None:
            return None
        if c.member is not Type.BOOL:
            self.error(text.at(e.test.span), f"the condition of 'a if condition else b' must be a boolean or a group "
                       f"of them, but this is {c.a}")
            return None
        if a.member is not b.member or a.member not in (Type.NUMBER, Type.BOOL):
            self.error(text.at(e.span), "both sides of 'a if condition else b' must have one type, member by "
                       f"member, not {a.a} and {b.a}")
            return None
        sizes = [(self.size(x), x) for x, t in ((e.test, c), (e.body, a), (e.orelse, b)) if t is not t.member]
        return self.grouped(e, text, "a if condition else b", sizes, a.member, [e.test, e.body, e.orelse])

    def visit_Call(self, e: ast.Call, text: Text) -> Type | None:
        return self.call(e, text)

    def visit_Peer(self, e: ast.Peer, text: Text) -> Type | None:
        return peer_type(self, e, text)

    def visit_Attribute(self, e: ast.Attribute, text: Text) -> Type | None:
        base = e.value.value if isinstance(e.value, ast.Index) else e.value
        if (isinstance(base, ast.Name) and self.version >= 1.3 and self.robot_counts and base.id not in self.types
                and base.id not in self.poisoned and not self.scopes and base.id not in self.later):
            robots = list(self.robot_counts)
            self.error(text.at(base.span), f"unknown robot '{base.id}'{did_you_mean(base.id, robots)}",
                       notes=("robots of this file: " + ", ".join(robots),))
            return None
        if (isinstance(base, ast.Name) and self.version >= 1.3 and not self.robot_counts and e.attr in PEER_VALUES
                and base.id not in self.types and base.id not in self.poisoned and base.id not in self.later):
            self.error(text.at(e.span), f"{base.id}.{e.attr} would read another robot's {e.attr}, and this file has "
                       "no robots", notes=("another robot is read by its name in a file of robots, as in leader.x",))
            return None
        t = self.infer(e.value, text)
        if t is None:
            return None
        fields = FIELDS.get(t)
        if fields is None:
            self.error(text.at(e.attr_span), f"{t.a} has no field '.{e.attr}'")
            return None
        if e.attr not in fields:
            names = ", ".join("." + f for f in fields)
            self.error(text.at(e.attr_span), f"{t.a} has the fields {names}; not '.{e.attr}'"
                       f"{did_you_mean(e.attr, fields)}")
            return None
        return fields[e.attr][1]

    def name(self, e: ast.Name, text: Text) -> Type | None:
        if self.scopes:
            inside = body_name(self, e, text)
            if not isinstance(inside, bool):
                return inside
        if e.id == self.current_let and e.id not in self.types:
            self.error(text.at(e.span), f"signal '{e.id}' reads itself: it is being computed; its value on the "
                       f"previous tick is prev({e.id}, initial)", notes=(
                           f"e.g. '{e.id}: prev({e.id}, 0) + 1' counts ticks; for counting and summing, "
                           "counter(...) and total(...) do it for you",))
            return None
        # a read-back name (format 1.3) a signal below takes is that signal's, here not yet computed
        if e.id in self.types and not (e.id in self.later and e.id in READ_BACK):
            self.used.add(e.id)
            return self.types[e.id]
        if e.id in self.poisoned or self.world_failed:
            return None  # its definition (or the world) is already reported: say nothing more
        if e.id in self.later:
            line = self.later[e.id].start_mark.line + 1
            self.error(text.at(e.span), f"signal '{e.id}' is used before it is defined (on line {line}); "
                       "'let' signals are evaluated in order")
            return None
        if e.id in FUNCTIONS or e.id in ACTIONS:
            self.error(text.at(e.span), f"'{e.id}' is a function: call it as {e.id}(...)")
            return None
        if e.id in self.robot_counts:
            if self.version < 1.3:
                self.error(text.at(e.span), later_format(f"reading another robot ({e.id}.x)", 1.3))
            elif self.robot_counts[e.id] > 1:
                self.error(text.at(e.span), f"'{e.id}' is a group of {self.robot_counts[e.id]} robots: read one "
                           f"robot's value, as in {e.id}[0].x", notes=(
                               f"a slice or a reduction of robots ({e.id}[0:2].x, min({e.id}), len({e.id})) is not a "
                               f"value: name each robot, as in min({e.id}[0].x, {e.id}[1].x)",))
            else:
                self.error(text.at(e.span), f"'{e.id}' is a robot: read one of its values, as in {e.id}.x",
                           notes=("another robot's x, y, heading, state and signals can be read",))
            return None
        if e.id in self.metric_names:
            self.error(text.at(e.span), f"'{e.id}' is a metric: metrics are summed up over the run for the "
                       "summary, and expressions cannot read them",
                       notes=("to use it here, compute it as a signal under 'let:' (e.g. 'held(...)' for a "
                              "duration, 'counter(...)' for a count, 'total(...)' for a sum; docs/language.md, "
                              "Time and memory)",))
            return None
        if e.id in self.unavailable:
            self.error(text.at(e.span), self.unavailable[e.id], notes=self.unavailable_notes.get(e.id, ()))
            return None
        hint = did_you_mean(e.id, self.types)
        notes = unknown_name_notes(e.id, self.types, self.distance)
        self.error(text.at(e.span), f"unknown name {quoted(e.id)}{hint}", notes=notes)
        return None

    def explained(self, e: ast.Expr) -> bool:
        """Whether an operand of the wrong type is a name two declarations share, whose clash
        is reported already: one message at the declaration, not one at every use."""
        return isinstance(e, ast.Name) and e.id in self.clashed

    def operands(self, e: ast.Expr, text: Text, op: str, args: list[ast.Expr], want: Type,
                 result: Type) -> Type | None:
        """An operator's operands: each ``want``, or a group of them (the operator then applies to
        each member: ``front - 0.5``); the result is ``result``, or a group of it."""
        ok = True
        sizes: list[tuple[int, ast.Expr]] = []
        for arg in args:
            t = self.infer(arg, text)
            if t is None:
                ok = False
            elif t is want.grouped and t is not want:
                sizes.append((self.size(arg), arg))
            elif t is not want:
                if not self.explained(arg):
                    self.error(text.at(arg.span), f"'{op}' needs {want.a}, but this is {t.a}",
                               notes=text_note(t) + list_note(arg, t))
                ok = False
        return self.grouped(e, text, op, sizes, result, args) if ok else None

    def grouped(self, e: ast.Expr, text: Text, op: str, sizes: list[tuple[int, ast.Expr]],
                result: Type, operands: list[ast.Expr]) -> Type | None:
        """``result``, or a group of it when operands are groups, all of one size; a value paired
        with every member is written into each, so it may not call a function with memory or a
        random one (it would run once per member)."""
        if not sizes:
            return result
        grouped_ids = {id(arg) for _, arg in sizes}
        for other in operands:
            if id(other) not in grouped_ids and not self.once_per_member(e, other, text):
                return None
        n, first = sizes[0]
        for m, arg in sizes[1:]:
            if m != n:
                self.error(text.at(arg.span), f"'{op}' pairs the members of two groups, which need one size: "
                           f"this has {m} members and the first {n}", notes=self.slice_note(text, first, n, arg, m))
                return None
        self.sizes[id(e)] = n
        return result.grouped

    def slice_note(self, text: Text, first: ast.Expr, n: int, other: ast.Expr, m: int) -> tuple[str, ...]:
        """Format 1.3: how to pair groups of two sizes, by a slice of the larger."""
        larger = first if n > m else other
        source = text.value[larger.span[0]:larger.span[1]]
        if self.version < 1.3 or len(source) > 40:
            return ()
        if not isinstance(larger, ast.Name | ast.Group | ast.Call | ast.Index | ast.Slice):
            source = f"({source})"
        return (f"to pair the first {min(n, m)} members of each, slice the larger: {source}[0:{min(n, m)}]",)

    def once_per_member(self, e: ast.Expr, value: ast.Expr, text: Text) -> bool:
        """False, after saying so, when ``value`` (paired with every member of a group by ``e``)
        calls a function with memory or a random one: each member would call it again, advancing
        its memory or drawing anew once per member."""
        for n in ast.walk(value):
            if not (isinstance(n, ast.Call) and (n.func in STATEFUL or n.func in RANDOM)) or (
                    id(n) in self.self_prev and self.version >= 1.3):
                continue  # a signal's own last value is read, not kept: each member's own (format 1.3)
            if id(n) in self.per_member_reported:
                return False  # said at the operator it is paired by first
            self.per_member_reported.add(id(n))
            what = "keeps memory from tick to tick" if n.func in STATEFUL else "draws a random number"
            call = text.value[n.span[0]:n.span[1]]
            name = next(c for c in ("p", "p1", "p2", "p3", "_p") if c not in self.types and c not in self.later)
            whole = text.value[e.span[0]:e.span[1]]
            at = n.span[0] - e.span[0], n.span[1] - e.span[0]
            use = f"{whole[:at[0]]}{name}{whole[at[1]:]}"
            if len(call) > 60:
                call = f"{n.func}(...)"
            self.error(text.at(n.func_span), f"{n.func}() {what}, but here it is paired with every member of a "
                       "group, so it would run once per member",
                       notes=(f"give it a signal of its own: '{name}: {call}', then "
                              + (f"'{use}'" if len(use) <= 80 else f"'{name}' in its place"),))
            return False
        return True

    def size(self, e: ast.Expr) -> int:
        """How many members a group-typed expression has."""
        if isinstance(e, ast.Name) and self.scopes and e.id in self.scopes[-1][1]:
            return self.scopes[-1][1][e.id][1]  # a function's parameter: its argument's
        if isinstance(e, ast.Name) and e.id in self.group_sizes:
            return self.group_sizes[e.id]
        if isinstance(e, ast.Name) and e.id in self.lists:
            return len(self.lists[e.id])  # a list of rows: how many
        return self.sizes[id(e)]

    def group(self, e: ast.Group, text: Text) -> Type | None:
        """[a, b, c]: members all numbers or all booleans; a range's missing names in one message."""
        if e.ranged:
            missing = [m for m in e.members if isinstance(m, ast.Name) and m.id not in self.types
                       and m.id not in self.poisoned]  # a failed lidar's beams are reported already
            if missing and not self.world_failed:
                names = [m.id for m in missing if isinstance(m, ast.Name)]
                which = names[0] if len(names) == 1 else f"{names[0]} .. {names[-1]}"
                near = [n for n in self.types if n.rstrip("0123456789") == names[0].rstrip("0123456789")]
                notes = (f"names of this kind: {range_text(near)}",) if near else ()
                self.error(text.at(e.span), f"{text.value[e.span[0]:e.span[1]]} names {which}, which "
                           f"{'does' if len(names) == 1 else 'do'} not exist", notes=notes)
                return None
        types = [self.infer(m, text) for m in e.members]
        if None in types:
            return None
        first = types[0]
        for m, t in zip(e.members, types):
            if t not in (Type.NUMBER, Type.BOOL) or t is not first:
                assert t is not None and first is not None
                also = f", and the first is {first.a}" if t in (Type.NUMBER, Type.BOOL) else ""
                table = all(isinstance(g, ast.Group) and all(isinstance(v, ast.Number | ast.Neg) for v in g.members)
                            for g in e.members)  # [[1, 2], [3, 4]]: numbers written out, a list parameter's
                self.error(text.at(m.span), f"a group's members are all numbers or all booleans; this one is "
                           f"{t.a}{also}", notes=("a table of numbers is a list parameter (format 1.3): put it under "
                                                  "'params:', as in 'params: {waypoints: [[0, -1], [3, -1]]}'",)
                           if table and self.version >= 1.3 else ())
                return None
        self.sizes[id(e)] = len(e.members)
        assert first is not None
        return first.grouped

    def index(self, e: ast.Index, text: Text) -> Type | None:
        """front[2]: a member, counted from 0; a number written there must be one of them."""
        t = self.infer(e.value, text)
        k = self.infer(e.index, text)
        if t is None or k is None:
            return None
        if t not in (Type.NUMBERS, Type.BOOLS, Type.LIST):
            self.error(text.at(e.value.span), f"only a group or a list has members to pick with [...]; this is {t.a}")
            return None
        noun = "row" if t is Type.LIST else "member"
        if k is not Type.NUMBER:
            self.error(text.at(e.index.span), f"a {noun} is picked by its place, a number from 0; this is {k.a}")
            return None
        if t is Type.LIST:
            return self.row(e, text)
        n = self.size(e.value)
        place, robot = self.place(e.index), ""
        listed = isinstance(e.value, ast.Name) and e.value.id in self.lists  # format 1.3: its place per robot
        for who, constants in (self.member_constants if listed else self.robot_constants) if place is None else ():
            value = self.place(e.index, constants)
            if isinstance(value, int | float) and not (float(value).is_integer() and 0 <= value < n):
                place, robot = value, who  # the first robot whose place is outside the group
                break
        if place is None or isinstance(place, bool) or not isinstance(place, int | float):
            return t.member  # known only while running: a place outside the group is a runtime fault
        source = text.value[e.index.span[0]:e.index.span[1]]
        shown = f"not {place_text(place)}" if literal(e.index) else f"'{source}' is {place_text(place)}" + (
            f" for robot {robot}" if robot else "")
        if not float(place).is_integer():
            fraction = place == place and abs(place) != float("inf")  # round(inf) is inf: no hint to round
            hint = (("round it, as in front[round(x)], if a fraction is meant to pick the nearest",) if fraction
                    else (f"this group's places are 0 to {n - 1}",))
            self.place_error(e, text, f"a member is picked by its place, a whole number from 0; {shown}",
                             notes=hint + self.set_note(e.index))
            return None
        if not 0 <= place < n:
            notes = ("places count from 0: the first member is [0]" + (f", the last [{n - 1}]" if place < 0 else ""),)
            self.place_error(e, text, f"this group has {n} member{'s' if n != 1 else ''}"
                             f", at places 0 to {n - 1}; {shown}", notes=notes + self.set_note(e.index))
            return None
        return t.member

    def row(self, e: ast.Index, text: Text) -> Type | None:
        """waypoints[i] (format 1.3): a row of a list parameter, a group of numbers; a place known before the
        run must be one of its rows, and one read while running is written into each of the row's values."""
        assert isinstance(e.value, ast.Name)
        rows = self.lists[e.value.id]
        n, width = len(rows), len(rows[0])  # type: ignore[arg-type]
        place, robot = self.place(e.index), ""
        for who, constants in self.member_constants if place is None else ():  # 'index', a robot's own parameters
            value = self.place(e.index, constants)
            if isinstance(value, int | float) and not (float(value).is_integer() and 0 <= value < n):
                place, robot = value, who  # the first robot with no row at its place
                break
        if isinstance(place, int | float) and not isinstance(place, bool):
            source = text.value[e.index.span[0]:e.index.span[1]]
            shown = (f"not {place_text(place)}" if literal(e.index) else f"'{source}' is {place_text(place)}"
                     + (f" for robot {robot}" if robot else ""))
            if not float(place).is_integer() or not 0 <= place < n:
                whole = float(place).is_integer() or place != place or abs(place) == float("inf")
                notes: tuple[str, ...] = (f"its rows are at places 0 to {n - 1}" + (
                    "" if whole else f"; round a fraction, as in {e.value.id}[round(i)]"),)
                if robot and whole:
                    notes += ("each robot picks the row at its own place: give the list a row for every robot",)
                self.place_error(e, text, f"list '{e.value.id}' has {n} "
                                 f"row{'s' if n != 1 else ''}, at places 0 to {n - 1}; {shown}", notes=notes)
                return None
        elif width > 1:  # the place is written into each value: nothing with memory or random in it
            risky = [n for n in ast.walk(e.index) if isinstance(n, ast.Call) and id(n) not in self.self_prev
                     and (n.func in STATEFUL or n.func in RANDOM)]  # a signal's own last value is read, not kept
            if risky and not self.once_per_member(e, risky[0], text):
                return None
        self.sizes[id(e)] = width
        return Type.NUMBERS

    def slice(self, e: ast.Slice, text: Text) -> Type | None:
        """front[0:4]: the members from place 0 up to place 4, not including it, as a group (format 1.3).
        Its bounds are known before the run, since a group's size is."""
        t = self.infer(e.value, text)
        bounds = [b for b in (e.lower, e.upper) if b is not None]
        kinds = [self.infer(b, text) for b in bounds]
        if self.version < 1.3:
            self.error(text.at(e.span), later_format("a slice [a:b]", 1.3))
            return None
        if t is None or None in kinds:
            return None
        if t not in (Type.NUMBERS, Type.BOOLS):
            self.error(text.at(e.value.span), f"only a group has members to slice with [a:b]; this is {t.a}",
                       notes=("a slice takes a run of a group's members, as in front[0:4] of front: sonar1..sonar8",))
            return None
        n = self.size(e.value)
        places: list[int] = []
        for b, k in zip(bounds, kinds):
            source = text.value[b.span[0]:b.span[1]]
            if k is not Type.NUMBER:
                assert k is not None  # None in kinds returned above
                self.error(text.at(b.span), f"a slice's bound is a place, a number from 0; this is {k.a}")
                return None
            place = self.place(b)
            if not isinstance(place, int | float) or isinstance(place, bool):
                own = self.robot_constants and all(self.place(b, constants) is not None
                                                   for _, constants in self.robot_constants)
                why = "reads a parameter each robot sets for itself" if own else "is known only while running"
                self.error(text.at(b.span), f"a slice's bounds are known before the run, the same for every robot: "
                           f"'{source}' {why}", notes=("a group's size is fixed when the file is compiled: write "
                                                       "numbers or parameters every robot shares; to pick one member "
                                                       "while running, use front[k]",))
                return None
            shown = f"not {place:g}" if literal(b) else f"'{source}' is {place:g}"
            if not (float(place).is_integer() and 0 <= place <= n):
                members = f"{n} member{'s' if n != 1 else ''}"
                message = (f"a slice's bound is a whole number; {shown}" if not float(place).is_integer() else
                           f"a slice's bound is a place from 0, and a slice does not count from the end; {shown}"
                           if place < 0 else f"this group has {members}, so a slice's bound is at most {n}; {shown}")
                self.error(text.at(b.span), message, notes=(
                    f"a slice [a:b] takes the places from a up to b, not including b: this group's [0:{n}] is all "
                    f"of its {members}", *self.set_note(b)))
                return None
            places.append(int(place))
        lower = places[0] if e.lower is not None else 0
        upper = places[-1] if e.upper is not None else n
        if lower >= upper:  # the example fits the group: [0:4] of 8 sonars, [2:3] of 3 members
            first = min(lower, n - 1)
            example = "[0:4] takes places 0, 1, 2 and 3" if n >= 4 else f"[{first}:{first + 1}] takes place {first}"
            self.error(text.at(e.span), f"this slice is empty: [{lower}:{upper}] takes the places from {lower} up to "
                       f"{upper}, not including {upper}", notes=(example,))
            return None
        self.sizes[id(e)] = upper - lower
        return t

    def known(self, e: ast.Expr) -> object | None:
        """The value of e known before the run, as the code generator folds it; None if it is not."""
        return known_value(e, self.constants, self.scopes)

    def set_note(self, e: ast.Expr) -> tuple[str, ...]:
        """Where a value known before the run comes from the command line: '--set k=7', for its message."""
        names = dict.fromkeys(n.id for n in ast.walk(e) if isinstance(n, ast.Name) and n.id in self.set_values)
        settings = ", ".join(shown_setting(name, self.set_values[name]) for name in names)
        return (f"with {settings} of the command line",) if names else ()

    def place(self, e: ast.Expr, constants: dict[str, object] | None = None) -> object | None:
        """A member's place or a slice's bound known before the run: as ``known``, and also a group's
        ``len()`` and a rounding of what is known (front[round(k)], front[1:len(front)]) in format 1.3
        (before it, front[round(k)] outside the group stays a fault while running)."""
        return known_value(e, self.constants if constants is None else constants, self.scopes,
                           self.lengths if self.version >= 1.3 else None)

    def compare(self, e: ast.Compare, text: Text) -> Type | None:
        inferred = [self.infer(o, text) for o in e.operands]
        types = [t for t in inferred if t is not None]
        if len(types) != len(inferred):
            return None
        if Type.TEXT in types:
            other = types[1] if types[0] is Type.TEXT else types[0]
            at = e.operands[types.index(Type.TEXT)]
            if other is Type.STATE:
                name = at.value if isinstance(at, ast.Text) else "follow"
                state = e.operands[1 - types.index(Type.TEXT)] if len(e.operands) == 2 else None
                whose = text.value[state.span[0]:state.span[1]] if isinstance(state, ast.Peer) else "state"
                self.error(text.at(at.span), f"a state is compared with a state's name, without quotes: write "
                           f"'{whose} == {name}'")
            else:
                self.error(text.at(at.span), "text cannot be compared: it is for a log's fields only",
                           notes=text_note(Type.TEXT))
            return None
        if Type.STATE in types:
            if len(e.operands) != 2 or e.ops[0] not in ("==", "!=") or types[0] is not types[1]:
                if any(self.explained(o) for o in e.operands):
                    return None
                self.error(text.at(e.span), "a state can only be compared with ==/!= to another state, "
                           "as in 'state == follow'")
                return None
            return Type.BOOL
        sizes: list[tuple[int, ast.Expr]] = []
        for (a, b, op, ta, tb) in zip(e.operands, e.operands[1:], e.ops, types, types[1:]):
            if op in ("==", "!=") and ta.member is tb.member is Type.BOOL:
                sizes += [(self.size(x), x) for x, t in ((a, ta), (b, tb)) if t is Type.BOOLS]
                continue
            for node, t in ((a, ta), (b, tb)):
                if t.member is not Type.NUMBER:
                    if not self.explained(node):
                        self.error(text.at(node.span), f"'{op}' compares numbers, but this is {t.a}")
                    return None
                if t is Type.NUMBERS:
                    sizes.append((self.size(node), node))
        return self.grouped(e, text, e.ops[0], sizes, Type.BOOL, list(e.operands))

    def call(self, e: ast.Call, text: Text) -> Type | None:
        if e.func == DETECTED:
            arg = e.args[0] if len(e.args) == 1 else None
            source = text.value[arg.span[0]:arg.span[1]] if arg is not None else ""
            group = isinstance(arg, ast.Group | ast.Slice) or (isinstance(arg, ast.Name) and arg.id in self.group_sizes)
            hint = (f"which members of a group see something: compare them, as in {source} < inf",) if group else ()
            if not isinstance(arg, ast.Name):
                self.error(text.at(e.span), "detected() takes one distance sensor's name, as in detected(sonar5)",
                           notes=hint)
                return None
            t = self.name(arg, text)
            if t is not None and arg.id not in self.distance:
                self.error(text.at(arg.span), f"detected() takes a distance sensor's name (sonar1 .. sonar16), "
                           f"and '{arg.id}' is not one", notes=hint)
                return None
            return Type.BOOL if t is not None else None
        if e.func in self.user_functions:
            self.called.add(e.func)
            return check_call(self, e, text, self.user_functions[e.func])
        if e.func == HEARD and e.func not in self.types:
            return heard_type(self, e, text)
        if e.func in self.poisoned:  # a function whose definition is reported: its calls stay quiet
            for arg in e.args:
                self.infer(arg, text)
            return None
        if e.func == "prev" and len(e.args) == 2:
            return self.prev(e, text)
        if e.func == "len":
            return self.length(e, text)
        if e.func in REDUCTIONS and len(e.args) == 1:
            reduced = self.reduction(e, text)
            if not isinstance(reduced, bool):
                return reduced
        f = FUNCTIONS.get(e.func)
        if e.func in REDUCTIONS and len(e.args) != 1 and (f is None or e.func == "mean"):
            message, notes = reduction_arity(e.func, len(e.args))  # sum(front, 1), any(a, b)
            self.error(text.at(e.span), message, notes)
            for arg in e.args:
                self.infer(arg, text)
            return None
        if f is None:
            self.unknown_call(e, text)
            return None
        return self.built_in(e, text, f)

    def unknown_call(self, e: ast.Call, text: Text) -> None:
        """A call of no function: what the name is instead (an aggregate, an action, the file's own
        'heard'), or the nearest names; its arguments are still checked, a channel's not."""
        notes: tuple[str, ...] = ()
        messages: tuple[str, ...] = ()
        meant = ""
        if e.func in AGGREGATES:
            message = f"'{e.func}' is a metric aggregate: it can only be the outer call of a 'metrics:' entry"
            notes = (("in a signal, counter(c) counts how many times c became true; count(...) of a group "
                      "of booleans, as in count(front < 0.5), counts the members that hold",)
                     if e.func == "count" else ())
        elif e.func in ACTIONS or e.func == SAY:
            message = f"'{e.func}' is an action: it goes after 'then', not inside an expression"
        elif e.func == HEARD:  # the file's own name 'heard' hides the function (format 1.3)
            message = f"'heard' is a {self.kinds.get(HEARD, 'name')} of this file, which hides heard()"
            notes = ("give it another name to hear a channel with heard(channel)",)
        elif e.func in MEANT:
            message = f"unknown function '{e.func}' (did you mean {MEANT[e.func]}?)"
            notes = function_notes(e.func, nearest=False)
        else:
            messages = (HEARD, SAY) if self.version >= 1.3 else ()
            meant = did_you_mean(e.func, [*FUNCTION_NAMES, *messages])
            message = f"unknown function '{e.func}'{meant}"
            notes = function_notes(e.func, extra=messages[:1])
        self.error(text.at(e.func_span), message, notes)
        # say's first argument is a channel, not a value; so is that of a mistyped heard or say
        channel = e.func == SAY or any(meant == f" (did you mean '{m}'?)" for m in messages)
        for arg in e.args[len(e.args) if e.func == HEARD else 1 if channel else 0:]:  # values, not channels
            self.infer(arg, text)
        return None

    def built_in(self, e: ast.Call, text: Text, f: Function) -> Type | None:
        """A call of a built-in function: its arguments' number and types; given groups where it takes
        one value (format 1.3), it applies member by member and is a group."""
        n = len(e.args)
        fixed = len(f.params) - f.optional
        if n == 0 and e.func in REDUCTIONS:  # min(): a group, or numbers
            self.error(text.at(e.span), *reduction_arity(e.func, n))
            return None
        if (not fixed <= n <= len(f.params) and not f.variadic) or (f.variadic and n < len(f.params)):
            self.error(text.at(e.span),
                       arity_message(f.name, f.names or tuple(str(p) for p in f.params), n, f.variadic, f.optional))
            return None
        ok = True
        sizes: list[tuple[int, ast.Expr]] = []  # the arguments that are groups: the call applies member by member
        for i, arg in enumerate(e.args):
            want = f.params[min(i, len(f.params) - 1)]
            t = self.infer(arg, text)
            later: tuple[str, ...] = ()
            if t is not None and t is want.grouped and t is not want:
                if self.version >= 1.3:
                    sizes.append((self.size(arg), arg))
                    continue
                later = (later_format(f"applying {f.name}() to each member of a group", 1.3),)
            ok = self.matches(text, arg, t, want, f"argument {i + 1} of {f.name}()", later) and ok
        if f.name == "randint":
            ok = self.whole_bounds(e, text) and ok
        if not ok:
            return None
        return self.grouped(e, text, f"{f.name}()", sizes, f.returns, list(e.args))

    def length(self, e: ast.Call, text: Text) -> Type | None:
        """len(waypoints), len(front) (format 1.3): how many rows a list has, members a group; known before the run."""
        if self.version < 1.3:
            self.error(text.at(e.func_span), later_format("len()", 1.3))
            return None
        if len(e.args) != 1:
            self.error(text.at(e.span), f"len() takes 1 argument, a list or a group, given {len(e.args)}")
            return None
        t = self.infer(e.args[0], text)
        if t is None:
            return None
        if t not in (Type.LIST, Type.NUMBERS, Type.BOOLS):
            self.error(text.at(e.args[0].span), f"len() takes a list or a group, but this is {t.a}")
            return None
        self.lengths[id(e)] = self.size(e.args[0])
        return Type.NUMBER

    def reduction(self, e: ast.Call, text: Text) -> Type | bool | None:
        """min(front), any(front < 0.5), ...: a group's reduction; False when the argument is not a
        group and the name is also a function of other things (min of numbers, mean of an image)."""
        r = REDUCTIONS[e.func]
        t = self.infer(e.args[0], text)
        if t is None:
            return None
        if t is r.takes:
            return r.returns
        if t is Type.LIST:
            self.error(text.at(e.args[0].span), f"{e.func}() takes a group, and this is a list of rows: take it of a "
                       "row, as in " + (f"{e.func}({e.args[0].id}[i])" if isinstance(e.args[0], ast.Name) else
                                        f"{e.func}(waypoints[i])"), notes=list_note(e.args[0], t))
            return None
        if t in (Type.NUMBERS, Type.BOOLS):
            self.error(text.at(e.args[0].span), f"{e.func}() takes {r.takes.a}, but this is {t.a}",
                       notes=(("to count the members that hold a condition, write count(front < 0.5)",)
                              if e.func in ("sum", "mean") else ()))
            return None
        if e.func in AGGREGATES or (e.func in FUNCTIONS and (e.func != "mean" or t is Type.IMAGE)):
            return False  # min(x) is refused as min() of too few numbers; mean(img) is the image's
        example = "front < 0.5" if r.takes is Type.BOOLS else "sonar1..sonar8"
        notes: tuple[str, ...] = ()
        if e.func == "sum":
            notes = ("for a running sum over the ticks, use total(x)",)
        self.error(text.at(e.args[0].span), f"{e.func}() takes a group, as in {e.func}({example}); "
                   f"this is {t.a}", notes=notes)
        return None

    def whole_bounds(self, e: ast.Call, text: Text) -> bool:
        """randint's bounds, where written as numbers, are within +-WHOLE_LIMIT: exact as floats."""
        for arg in e.args:
            if literal(arg) and not abs(fold(arg, {})) <= WHOLE_LIMIT:  # type: ignore[arg-type]
                self.error(text.at(arg.span), f"randint() takes bounds between -{WHOLE_LIMIT} and {WHOLE_LIMIT} "
                           "(2**53: whole numbers a float holds exactly)")
                return False
        return True

    def prev(self, e: ast.Call, text: Text) -> Type | None:
        """prev(x, initial) takes a number or a boolean, and an initial value of the same type.

        Inside signal x's own definition, prev(x, initial) is x on the previous tick: its type
        is the initial value's, and the signal must come out of that type (checked by lets())."""
        x = e.args[0]
        if isinstance(x, ast.Name) and x.id == self.current_let and not self.scopes and x.id not in self.types:
            b = self.infer(e.args[1], text)
            group = b in (Type.NUMBERS, Type.BOOLS) and self.version >= 1.3  # a group signal: each member's own
            if b is not None and b not in (Type.NUMBER, Type.BOOL) and not group:
                later = ((later_format("a group signal reading its own members", 1.3),)
                         if b in (Type.NUMBERS, Type.BOOLS) else ())
                self.error(text.at(e.args[1].span), f"prev({x.id}, ...) keeps a number or a boolean, or in format "
                           f"1.3 a group, not {b.a}" if not later else f"prev() keeps a number or a boolean, not {b.a}",
                           notes=later)
                return None
            if group:
                self.sizes[id(e)] = self.size(e.args[1])
            self.self_prev.add(id(e))
            if self.group_self and b in (Type.NUMBER, Type.BOOL):  # each member starts from b (lets())
                self.sizes[id(e)] = self.group_self
                b = b.grouped
            self.self_prev_types.append((e, b))
            return b
        a, b = (self.infer(arg, text) for arg in e.args)
        if a is None or b is None:
            return None
        if a in (Type.NUMBERS, Type.BOOLS) and self.version >= 1.3:  # member by member, a memory each
            if b is not a.member:
                self.error(text.at(e.args[1].span), f"prev()'s initial value must be {a.member.a} like each member "
                           f"of its first argument, but this is {b.a}")
                return None
            return self.grouped(e, text, "prev()", [(self.size(x), x)], a.member, list(e.args))
        if a not in (Type.NUMBER, Type.BOOL):
            later = ((later_format("applying prev() to each member of a group", 1.3),)
                     if a in (Type.NUMBERS, Type.BOOLS) else ())
            self.error(text.at(e.args[0].span), f"prev() keeps a number or a boolean, not {a.a}", notes=later)
            return None
        if b is not a:
            self.error(text.at(e.args[1].span), f"prev()'s initial value must be {a.a} like its first "
                       f"argument, but this is {b.a}")
            return None
        return a


def list_note(e: ast.Expr, t: Type) -> tuple[str, ...]:
    """The hint for a list of rows used as a value: pick a row, or a number of one."""
    if t is not Type.LIST or not isinstance(e, ast.Name):
        return ()
    return (f"pick a row with {e.id}[i], a number of it with {e.id}[i][0], or count the rows with len({e.id})",)
