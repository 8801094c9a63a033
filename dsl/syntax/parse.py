"""Rule and expression strings to AST: the lark grammar in ``grammar.lark``, LALR.

``parse_rule`` and ``parse_expr`` return ``labsim.dsl.syntax.ast`` nodes whose spans are offsets into
the string; ``ParseError`` carries the offsets of a problem and a message saying what was
expected. ``parse_label`` reads a slider's label, text with ``{expression:format}`` fields,
around ``parse_expr``. No lark type escapes this module.

Over 500 lines: the tree's transformer and the words for each of lark's errors both read the
grammar's terminals and rules, and a rule added to the grammar changes both.
"""
from __future__ import annotations

import dataclasses
import functools
import re
import sys
from dataclasses import dataclass
from typing import Any, TypeAlias

from lark import Lark, Token, Transformer, Tree, v_args
from lark import __version__ as lark_version
from lark.exceptions import UnexpectedCharacters, UnexpectedEOF, UnexpectedInput, UnexpectedToken, VisitError
from lark.tree import Meta

from labsim.dsl.library.builtins import PRINTS
from labsim.dsl.syntax import ast
from labsim.foundation.cache import cache_dir
from labsim.foundation.numbers import NumberError, to_float

MAX_DEPTH = 100  # deeper expressions are refused: nobody writes them, and they'd exhaust the stack


@dataclass(frozen=True)
class ParseError(Exception):
    start: int
    end: int
    message: str
    notes: tuple[str, ...] = ()


@functools.lru_cache(maxsize=1)
def _parser() -> Lark:
    # The basic lexer keeps keywords keywords everywhere: lark's contextual lexer would read
    # `then` in `if a and then ...` as a name.
    # Building the LALR tables takes 60-70 ms, a third of a cold `labsim check`: lark keeps
    # them in a file in labsim's cache folder (labsim.foundation.cache). The file starts
    # with a hash of the grammar and the options, which lark checks before it uses it, and
    # lark rebuilds the tables when the file is missing, stale, unreadable or cannot be
    # written; without a cache folder nothing is kept.
    folder = cache_dir()
    cache: str | bool = False
    if folder is not None:
        cache = str(folder / f"grammar-lark{lark_version}-py{sys.version_info[0]}{sys.version_info[1]}.cache")
    return Lark.open("grammar.lark", rel_to=__file__, parser="lalr", lexer="basic", cache=cache,
                     start=["rule", "expr"], propagate_positions=True, maybe_placeholders=True)


def parse_rule(text: str, robots: frozenset[str] = frozenset()) -> ast.Rule:
    result = _parse(text, "rule", robots)
    assert isinstance(result, ast.Rule)
    return result


def parse_expr(text: str, robots: frozenset[str] = frozenset()) -> ast.Expr:
    result = _parse(text, "expr", robots)
    assert isinstance(result, ast.Expr)
    return result


LabelPart: TypeAlias = str | tuple[ast.Expr, str]  # literal text, or an expression and its format spec


_PRINTF = re.compile(r"%([+\- 0]?\d{0,2}(?:\.\d{1,2})?)([dfeEgGi])")


def parse_printf(text: str, name: str) -> tuple[LabelPart, ...] | None:
    """'Arm Speed: %.2f', the form CoppeliaSim's scripts use: one field, the value ``name``.

    None when the text has no printf field or has braces (then it is the brace form). ``%%``
    is a percent sign; a second field is an error, since a label's printf form shows one value.
    """
    fields = list(_PRINTF.finditer(text.replace("%%", "\0\0")))
    if not fields or "{" in text:
        return None
    if len(fields) > 1:
        m = fields[1]
        raise ParseError(m.start(), m.end(), "a label's printf form shows one value (the slider's); "
                         "for more, use {expression:.2f} fields")
    m = fields[0]
    spec = m.group(1) + ("d" if m.group(2) == "i" else m.group(2))
    parts: list[LabelPart] = []
    if m.start():
        parts.append(text[:m.start()].replace("%%", "%"))
    parts.append((ast.Name(name, span=(m.start(), m.end())), spec))
    if m.end() < len(text):
        parts.append(text[m.end():].replace("%%", "%"))
    return tuple(parts)


def parse_label(text: str, robots: frozenset[str] = frozenset()) -> tuple[LabelPart, ...]:
    """'Arm Speed: {0.02 * arm:.2f}': literal text and {expression:format} fields, in order.

    ``{{`` and ``}}`` stand for braces. The expressions' spans are offsets into the whole text.
    """
    parts: list[LabelPart] = []
    i, literal = 0, ""
    while i < len(text):
        ch = text[i]
        if ch in "{}" and text[i:i + 2] in ("{{", "}}"):
            literal += ch
            i += 2
            continue
        if ch == "}":
            raise ParseError(i, i + 1, "unmatched '}' in a label (write '}}' for a brace)")
        if ch != "{":
            literal += ch
            i += 1
            continue
        end = text.find("}", i)
        if end < 0:
            raise ParseError(i, i + 1, "unclosed '{' in a label (write '{{' for a brace)")
        field_text = text[i + 1:end]
        at = _spec_colon(field_text)
        expr_text, colon, spec = (field_text[:at], ":", field_text[at + 1:]) if at >= 0 else (field_text, "", "")
        if colon and not _FORMAT_SPEC.fullmatch(spec):
            start = i + 1 + len(expr_text) + 1
            raise ParseError(start, start + len(spec), f"'{spec}' is not a number format; use e.g. .2f, .1%, 5.1f or d")
        try:
            expr = parse_expr(expr_text, robots)
        except ParseError as e:
            raise ParseError(i + 1 + e.start, i + 1 + e.end, e.message, e.notes) from None
        if literal:
            parts.append(literal)
            literal = ""
        parts.append((_shift(expr, i + 1), spec))
        i = end + 1
    if literal:
        parts.append(literal)
    return tuple(parts)


def _spec_colon(field: str) -> int:
    """Where a field's format spec starts: its last ':' outside brackets (``{front[0:2]}`` has none,
    as a Python f-string's field has not); -1 if none."""
    depth, at = 0, -1
    for k, ch in enumerate(field):
        depth += (ch in "([") - (ch in ")]")
        if ch == ":" and depth == 0:
            at = k
    return at


_FORMAT_SPEC = re.compile(r"[<>^=]?[+\- ]?0?\d{0,2}(\.\d{1,2})?[fegdF%]?")


def _shift(e: ast.Expr, offset: int) -> ast.Expr:
    """An expression parsed from part of a string, its spans moved to the whole string's."""
    changes: dict[str, Any] = {}
    for f in dataclasses.fields(e):
        v = getattr(e, f.name)
        if f.name.endswith("span") and isinstance(v, tuple) and len(v) == 2:
            changes[f.name] = (v[0] + offset, v[1] + offset)
        elif isinstance(v, ast.Expr):
            changes[f.name] = _shift(v, offset)
        elif isinstance(v, tuple) and v and all(isinstance(x, ast.Expr) for x in v):
            changes[f.name] = tuple(_shift(x, offset) for x in v)
    return dataclasses.replace(e, **changes)


def _parse(text: str, start: str, robots: frozenset[str] = frozenset()) -> ast.Rule | ast.Expr:
    if not text.strip():
        what = "rule" if start == "rule" else "expression"
        raise ParseError(0, max(1, len(text)), f"empty {what}")
    _check_brackets(text)
    try:
        tree = _parser().parse(text, start=start)
    except UnexpectedInput as e:
        raise _translate(e, text, start) from None
    _check_depth(tree)
    try:
        return _ToAst(robots).transform(tree)
    except VisitError as e:  # a log text's own mistake, raised while building its action
        if isinstance(e.orig_exc, ParseError):
            raise e.orig_exc from None
        raise


def _check_brackets(text: str) -> None:
    opened: list[int] = []
    for i, ch in enumerate(text):
        if ch == "(":
            opened.append(i)
        elif ch == ")":
            if not opened:
                raise ParseError(i, i + 1, "unmatched ')'")
            opened.pop()
    if opened:
        raise ParseError(opened[-1], opened[-1] + 1, "unclosed '(': no matching ')'")


def _check_depth(tree: Tree) -> None:
    """Refuse trees deeper than MAX_DEPTH; a long flat sum (``a + b + c ...``, which the grammar
    nests to the left) is named as such, since nothing in it looks nested to the person who wrote it."""
    stack: list[tuple[Tree, int, int, int]] = [(tree, 1, 1, 1)]  # node, depth, its left chain's terms, its parent's
    while stack:
        node, depth, chain, parent_chain = stack.pop()
        if depth > MAX_DEPTH:
            start = getattr(node.meta, "start_pos", 0) or 0
            if max(chain, parent_chain) * 2 > depth:
                start = getattr(tree.meta, "start_pos", 0) or 0
                raise ParseError(start, start + 1, f"too many terms in one sum or product (labsim takes "
                                 f"up to about {MAX_DEPTH})",
                                 ("hint: split it into named signals under 'let:', e.g. 'a: ...' and "
                                  "'b: ...' of half the terms each, then 'total: a + b'",))
            raise ParseError(start, start + 1,
                             f"expression nested too deeply (more than {MAX_DEPTH} levels)",
                             ("hint: split it into named signals under 'let:'",))
        for k, child in enumerate(node.children):
            if isinstance(child, Tree):
                flat = k == 0 and node.data == child.data == "binary" and _family(node) == _family(child)
                stack.append((child, depth + 1, chain + 1 if flat else 1, chain))


def _family(node: Tree) -> str:
    """'+' for a sum, '*' for a product, '**' for a power: operators that chain to the left."""
    op = str(node.children[1]) if len(node.children) > 1 else ""
    return {"-": "+", "/": "*", "%": "*"}.get(op, op)


def _found(token: Token) -> str:
    if token.type == "$END":
        return "the end of the text"
    value = str(token.value)
    if len(value) > 40:  # a message quotes a long token's start, not the whole of it
        return f"'{value[:30]}...' ({len(value)} characters)"
    return f"'{value}'"


def _translate(e: UnexpectedInput, text: str, start: str) -> ParseError:
    pos = e.pos_in_stream if e.pos_in_stream is not None else len(text)
    if isinstance(e, UnexpectedCharacters):
        return (_assignment(text, pos) if start == "rule" else None) or _bad_character(text, pos, start)
    expected: set[str]  # terminal names
    if isinstance(e, UnexpectedEOF):
        expected = {str(t) for t in e.expected}
        token_text = "the end of the text"
        pos = len(text.rstrip())
        end = pos + 1
    else:
        assert isinstance(e, UnexpectedToken)
        if e.token.type == "_COLON" and text[:pos].count("[") <= text[:pos].count("]"):
            return _bad_character(text, pos, start)  # a ':' outside a slice's brackets: as before slices
        expected = set(e.expected)
        token_text = _found(e.token)
        if e.token.type == "$END":
            pos = len(text.rstrip())
            end = pos + 1
        else:
            end = pos + len(str(e.token.value))
    expected.discard("__IGNORE_0")
    # LALR's expected sets are broad, so the message is chosen by where we are in the text.
    words = text[:pos].split()
    token = e.token if isinstance(e, UnexpectedToken) else None
    habit = _habit(text, pos, end, token, expected, words) if token is not None and start == "rule" else None
    if habit is not None:
        return habit
    first = _RULE_START.match(text)
    if start == "rule" and (not words or pos == 0 or (first and first.group(1) not in RULE_WORDS)):
        word = first.group(1) if first else (text.split()[0] if text.split() else "")
        return _rule_start(word, text.find(word) if word else 0)
    inner = _unclosed(text, pos)
    if text[:pos].count("(") > text[:pos].count(")") and text[inner] == "(":
        if {"NAME", "NUMBER"} <= expected:
            return ParseError(pos, end, f"expected a value or an expression, found {token_text}")
        return ParseError(pos, end, f"expected ',' or ')', found {token_text}")
    if start == "rule":
        in_actions = words[0] in ("else", "always") or "then" in words
        if not in_actions and "THEN" in expected and not {"NAME", "NUMBER"} <= expected:
            return ParseError(pos, end, f"expected 'then' after the condition, found {token_text}")
        if in_actions:
            if "COMMA" in expected and words[-1] not in ("then", "else", "always", ","):
                return ParseError(pos, end, f"expected ',' between actions, found {token_text}")
            if words[-1] == "goto":
                return ParseError(pos, end, f"expected a state name after 'goto', found {token_text}")
            return ParseError(pos, end, "expected an action such as arc(...), move(...), stop() "
                                        f"or goto STATE, found {token_text}")
    if {"NAME", "NUMBER"} <= expected:
        return ParseError(pos, end, f"expected a value or an expression, found {token_text}")
    if "ELSE" in expected and "if" in words:
        return ParseError(pos, end, f"expected 'else' in 'a if condition else b', found {token_text}")
    if expected == {"NAME"}:
        return ParseError(pos, end, f"expected a name, found {token_text}")
    if inner >= 0 and text[inner] == "[" and "RSQB" in expected:
        return _in_brackets(text, inner, pos, end, expected, token_text)
    where = "the condition" if start == "rule" else "the expression"
    return ParseError(pos, end, f"unexpected {token_text}: expected an operator or the end of {where}")


def _in_brackets(text: str, inner: int, pos: int, end: int, expected: set[str], token_text: str) -> ParseError:
    """A mistake inside g[...] or a list [a, b], whose '[' is at inner."""
    opened = text[:inner].rstrip()  # what the bracket follows: a value for g[k], else a list
    index = bool(opened) and (opened[-1].isalnum() or opened[-1] in "_)]")
    comma = ", ','" if "COMMA" in expected and not index else ""
    return ParseError(pos, end, f"expected an operator{comma} or ']', found {token_text}")


def _unclosed(text: str, pos: int) -> int:
    """Where the innermost bracket, '(' or '[', open at pos is (-1 if none)."""
    opened: list[int] = []
    for k, ch in enumerate(text[:pos]):
        if ch in "([":
            opened.append(k)
        elif ch in ")]" and opened:
            opened.pop()
    return opened[-1] if opened else -1


def _habit(text: str, pos: int, end: int, token: Token, expected: set[str], words: list[str]) -> ParseError | None:
    """What a student used to another language wrote in a rule's actions, and what to write
    instead; None when the mistake is none of these."""
    before = text[:pos].rstrip()
    if token.type == "STRING" and before.endswith("f") and not before[:-1][-1:].isalnum():
        return ParseError(pos - 1, end, f"write the text without the 'f': log({token.value}) fills in "
                          "the {...} fields of its text")
    if token.type in ("PLUS", "PERCENT") and before.endswith(('"', "'")):
        return ParseError(pos, end, f"text cannot be joined with '{token.value}': write the values in "
                          'fields of the text, as in log("near {sonar5:.2f} m")')
    if not (words and ("then" in words or words[0] in ("else", "always"))):
        return None
    if token.type == "ELSE":
        rule = " ".join(text[pos:].split())  # the student's own else-rule, as the next line would read it
        rule = rule if len(rule) <= 60 else rule[:57] + "..."
        return ParseError(pos, end, f"'else' starts a rule of its own: write it on the next line, as '- {rule}'")
    if token.type == "LPAR" and len(words) >= 2 and words[-2] == "goto":
        return ParseError(pos, end, f"'goto' takes a state's name without parentheses: goto {words[-1]}")
    if expected == {"LPAR"}:
        if words[-1] in PRINTS and token.type == "STRING":
            return ParseError(pos - len(words[-1]) - 1, end, f"to print text, write log({token.value})")
        return ParseError(pos, end, f"expected '(' after '{words[-1]}', found {_found(token)}: an action "
                          f"takes its values in parentheses, as in {words[-1]}(...)")
    return None


def _assignment(text: str, pos: int) -> ParseError | None:
    """'state = follow' or 'x = 3' among a rule's actions: what sets a value in labsim instead."""
    words = text[:pos].split()
    if text[pos] != "=" or text.startswith("==", pos) or not ("then" in words or words[:1] in (["else"], ["always"])):
        return None
    after = text[pos + 1:].replace(",", " ").split() or ["STATE"]
    if words[-1] == "state":
        return ParseError(pos, pos + 1, f"a rule changes state with goto: write 'goto {after[0]}'")
    return ParseError(pos, pos + 1, "'=' sets nothing among a rule's actions: a value is computed under "
                      "'let:', and a rule changes state with 'goto STATE'")


_CHARACTER_HINTS = {
    "=<": ("'=<' is not an operator; write '<='", 2),
    "=>": ("'=>' is not an operator; write '>='", 2),
    "=": ("'=' is not a comparison; write '==' to compare", 1),
    "&&": ("'&&' is not an operator; write 'and'", 2),
    "||": ("'||' is not an operator; write 'or'", 2),
    "&": ("'&' is not an operator; write 'and'", 1),
    "|": ("'|' is not an operator; write 'or'", 1),
    "!": ("'!' is not an operator; write 'not' (or '!=' for 'not equal')", 1),
    "^": ("'^' is not an operator; write '**' for a power", 1),
    ":": ("unexpected ':': a rule reads 'if CONDITION then ACTION'", 1),
    ";": ("';' does not end or separate anything: separate actions with ','", 1),
}


RULE_WORDS = ("if", "else", "always", "when")
_RULE_START = re.compile(r"\s*([A-Za-z_][A-Za-z0-9_]*)")


def _rule_start(word: str, at: int) -> ParseError:
    return ParseError(at, at + max(1, len(word)), f"a rule starts with 'if', 'else', 'always' or 'when', not '{word}'",
                      ("e.g. 'if sonar5 <= 0.5 then arc(-2, 2)', 'else move(2)', or "
                       "'when rising(collided) then log(\"hit\")', which logs and goes on to the next rule",))


def _bad_character(text: str, pos: int, start: str = "rule") -> ParseError:
    if start != "rule" and text[pos] == ":":  # a signal, a condition: no rule to read
        return ParseError(pos, pos + 1, "unexpected ':' in an expression")
    for prefix in sorted(_CHARACTER_HINTS, key=len, reverse=True):
        if text.startswith(prefix, pos):
            message, length = _CHARACTER_HINTS[prefix]
            return ParseError(pos, pos + length, message)
    return ParseError(pos, pos + 1, f"unexpected character '{text[pos]}'")


def _span(meta: Meta) -> ast.Span:
    return (meta.start_pos, meta.end_pos)


def _tspan(token: Token) -> ast.Span:
    assert token.start_pos is not None and token.end_pos is not None  # the lexer places every token
    return (token.start_pos, token.end_pos)


@v_args(meta=True)
class _ToAst(Transformer):
    """lark tree to frozen dataclasses; tokens become str and float here. ``leader.x`` of one of
    ``robots``, the file's robots (format 1.3), is a ``Peer``."""

    def __init__(self, robots: frozenset[str] = frozenset()) -> None:
        super().__init__()
        self.robots = robots

    def if_rule(self, meta: Meta, c: list[Any]) -> ast.Rule:
        return ast.Rule("if", c[0], c[1], span=_span(meta))

    def else_rule(self, meta: Meta, c: list[Any]) -> ast.Rule:
        return ast.Rule("else", None, c[0], span=_span(meta))

    def always_rule(self, meta: Meta, c: list[Any]) -> ast.Rule:
        return ast.Rule("always", None, c[0], span=_span(meta))

    def named_rule(self, meta: Meta, c: list[Any]) -> ast.Rule:
        """``when COND then log(...)``: 'when' is read as a name, so a file may still use it as one."""
        if str(c[0]) != "when":
            raise _rule_start(str(c[0]), c[0].start_pos)
        return ast.Rule("when", c[1], c[2], span=_span(meta))

    def actions(self, meta: Meta, c: list[Any]) -> tuple[ast.Action | ast.Goto, ...]:
        return tuple(c)

    def goto(self, meta: Meta, c: list[Any]) -> ast.Goto:
        return ast.Goto(str(c[0]), span=_span(meta), state_span=_tspan(c[0]))

    def action(self, meta: Meta, c: list[Any]) -> ast.Action:
        args = c[1] if c[1] is not None else ()
        return ast.Action(str(c[0]), args, span=_span(meta), name_span=_tspan(c[0]))

    def text_action(self, meta: Meta, c: list[Any]) -> ast.Action:
        token = c[1]
        start = token.start_pos + 1  # inside the quotes
        try:
            parts = parse_label(str(token)[1:-1], self.robots)
        except ParseError as e:
            raise ParseError(start + e.start, start + e.end, e.message.replace("a label", "a log text"),
                             e.notes) from None
        text = tuple(p if isinstance(p, str) else (_shift(p[0], start), p[1]) for p in parts)
        # values after the text (print("hit", x)) are kept for the checker, which refuses them
        return ast.Action(str(c[0]), tuple(c[2:]), span=_span(meta), name_span=_tspan(c[0]), text=text)

    def arguments(self, meta: Meta, c: list[Any]) -> tuple[ast.Expr, ...]:
        return tuple(c)

    def ifexp(self, meta: Meta, c: list[Any]) -> ast.IfExp:
        return ast.IfExp(c[0], c[1], c[2], span=_span(meta))

    def or_(self, meta: Meta, c: list[Any]) -> ast.BoolOp:
        return ast.BoolOp("or", tuple(c), span=_span(meta))

    def and_(self, meta: Meta, c: list[Any]) -> ast.BoolOp:
        return ast.BoolOp("and", tuple(c), span=_span(meta))

    def not_(self, meta: Meta, c: list[Any]) -> ast.Not:
        return ast.Not(c[0], span=_span(meta))

    def compare(self, meta: Meta, c: list[Any]) -> ast.Compare:
        return ast.Compare(tuple(c[0::2]), tuple(str(t) for t in c[1::2]), span=_span(meta))

    def binary(self, meta: Meta, c: list[Any]) -> ast.Binary:
        if isinstance(c[0], ast.Text) or isinstance(c[2], ast.Text):  # "near %.2f" % x, "x" + "y"
            raise ParseError(*_tspan(c[1]), f"text cannot be joined with '{c[1]}': write the values in fields of "
                             'the text, as in log("near {sonar5:.2f} m")')
        return ast.Binary(str(c[1]), c[0], c[2], span=_span(meta))

    def power(self, meta: Meta, c: list[Any]) -> ast.Binary:
        return ast.Binary("**", c[0], c[1], span=_span(meta))

    def neg(self, meta: Meta, c: list[Any]) -> ast.Neg:
        return ast.Neg(c[1], span=_span(meta))

    def pos(self, meta: Meta, c: list[Any]) -> ast.Expr:
        return c[1]

    def number(self, meta: Meta, c: list[Any]) -> ast.Number:
        try:
            value = to_float(str(c[0]))  # the one rule for numbers: 1e309 is refused, not inf
        except NumberError as e:
            raise ParseError(meta.start_pos, meta.end_pos, str(e)) from None
        return ast.Number(value, span=_span(meta))

    def true(self, meta: Meta, c: list[Any]) -> ast.Bool:
        return ast.Bool(True, span=_span(meta))

    def false(self, meta: Meta, c: list[Any]) -> ast.Bool:
        return ast.Bool(False, span=_span(meta))

    def name(self, meta: Meta, c: list[Any]) -> ast.Name:
        return ast.Name(str(c[0]), span=_span(meta))

    def call(self, meta: Meta, c: list[Any]) -> ast.Call:
        args = c[1] if c[1] is not None else ()
        return ast.Call(str(c[0]), args, span=_span(meta), func_span=_tspan(c[0]))

    def attribute(self, meta: Meta, c: list[Any]) -> ast.Attribute | ast.Peer:
        base, attr = c[0], str(c[1])
        name = base.value if isinstance(base, ast.Index) else base
        if isinstance(name, ast.Name) and name.id in self.robots:  # leader.x, pioneer[2].x: another robot's
            member = base.index if isinstance(base, ast.Index) else ast.Number(0.0, span=name.span)
            return ast.Peer(name.id, member, attr, name is not base, span=_span(meta), robot_span=name.span,
                            attr_span=_tspan(c[1]))
        return ast.Attribute(base, attr, span=_span(meta), attr_span=_tspan(c[1]))

    def text(self, meta: Meta, c: list[Any]) -> ast.Text:
        return ast.Text(str(c[0])[1:-1], span=_span(meta))

    def group(self, meta: Meta, c: list[Any]) -> ast.Group:
        if c[0] is None:
            raise ParseError(meta.start_pos, meta.end_pos, "a group needs at least one member, as in [sonar4, sonar5]")
        if len(c[0]) > MAX_RANGE:
            raise ParseError(meta.start_pos, meta.end_pos,
                             f"a group holds at most {MAX_RANGE:,} members, and this one has {len(c[0]):,}",
                             notes=("a robot has at most a few dozen sensors of a kind, and a lidar 360 beams: "
                                    "name them by a range, as in lidar1..lidar360",))
        return ast.Group(tuple(c[0]), span=_span(meta))

    def index(self, meta: Meta, c: list[Any]) -> ast.Index:
        return ast.Index(c[0], c[1], span=_span(meta))

    def slice(self, meta: Meta, c: list[Any]) -> ast.Slice:
        return ast.Slice(c[0], c[1], c[2], span=_span(meta))

    def name_range(self, meta: Meta, c: list[Any]) -> ast.Group:
        """``sonar1..sonar8`` (or ``sonar1..8``): the names from the first number to the last, in order."""
        first, last = c
        head = _NUMBERED.fullmatch(str(first))
        tail = _NUMBERED.fullmatch(str(last)) if last.type == "NAME" else re.fullmatch(r"()(\d+)", str(last))
        if head is None:
            raise ParseError(*_tspan(first), f"a range of names runs between two numbered names, as in "
                             f"sonar1..sonar8; '{first}' ends in no number")
        if tail is None or (tail.group(1) and tail.group(1) != head.group(1)):
            raise ParseError(*_tspan(last), f"a range of names runs between two numbered names of one kind, as "
                             f"in {head.group(1)}1..{head.group(1)}8; not '{last}'")
        a, b = int(head.group(2)), int(tail.group(2))
        if abs(b - a) >= MAX_RANGE:
            raise ParseError(meta.start_pos, meta.end_pos, f"a range of names holds at most {MAX_RANGE} members, "
                             f"and this one has {abs(b - a) + 1}")
        step = 1 if b >= a else -1
        names = [f"{head.group(1)}{k}" for k in range(a, b + step, step)]
        spans = [_span(meta)] * len(names)
        spans[0], spans[-1] = _tspan(first), _tspan(last)
        return ast.Group(tuple(ast.Name(n, span=sp) for n, sp in zip(names, spans)), True, span=_span(meta))


_NUMBERED = re.compile(r"([A-Za-z_][A-Za-z0-9_]*?)(\d+)")
# members of one group (a range of names or a list): a robot has at most a few dozen sensors of a
# kind; a reduction of a larger group would be one Python expression too deep to compile
MAX_RANGE = 1000
