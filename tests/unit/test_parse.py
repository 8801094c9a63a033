"""Rule and expression strings to AST: structure, spans, and what a syntax error says."""
from __future__ import annotations

import pytest

from labsim.dsl.syntax import ast
from labsim.dsl.syntax.parse import ParseError, parse_expr, parse_rule

N, V = ast.Number, ast.Name


def test_precedence_and_chains() -> None:
    assert parse_expr("a + b * c") == ast.Binary("+", V("a"), ast.Binary("*", V("b"), V("c")))
    assert parse_expr("-2 ** 2") == ast.Neg(ast.Binary("**", N(2.0), N(2.0)))
    assert parse_expr("0.3 < sonar8 <= 1") == ast.Compare((N(0.3), V("sonar8"), N(1.0)), ("<", "<="))
    assert parse_expr("not a < b and c") == ast.BoolOp("and", (ast.Not(ast.Compare((V("a"), V("b")), ("<",))), V("c")))
    assert parse_expr("a or b and c") == ast.BoolOp("or", (V("a"), ast.BoolOp("and", (V("b"), V("c")))))
    assert parse_expr("x if c else y") == ast.IfExp(V("x"), V("c"), V("y"))
    assert parse_expr("a - -b") == ast.Binary("-", V("a"), ast.Neg(V("b")))
    assert parse_expr("1e-3 + .5") == ast.Binary("+", N(0.001), N(0.5))


def test_keywords_are_not_names_but_prefixes_are() -> None:
    assert parse_expr("iffy + notice + orbit") == ast.Binary(
        "+", ast.Binary("+", V("iffy"), V("notice")), V("orbit"))


def test_rules_and_actions() -> None:
    r = parse_rule("if sonar5 <= front then arc(-2, 2), goto follow")
    assert r.kind == "if"
    assert r.actions == (ast.Action("arc", (ast.Neg(N(2.0)), N(2.0))), ast.Goto("follow"))
    assert parse_rule("else stop()") == ast.Rule("else", None, (ast.Action("stop", ()),))
    assert parse_rule("always move(1)").kind == "always"


def test_an_action_with_text_keeps_the_values_after_it_for_the_checker() -> None:
    (action,) = parse_rule('always print("wall!", x, 2)').actions
    assert action == ast.Action("print", (V("x"), N(2.0)), text=("wall!",))
    assert isinstance(action, ast.Action) and action.args[0].span == (22, 23)


def test_spans_are_offsets_into_the_string() -> None:
    r = parse_rule("if sonar5 <= front then arc(-2, 2)")
    cond = r.condition
    assert isinstance(cond, ast.Compare)
    assert cond.span == (3, 18)
    assert cond.operands[0].span == (3, 9)
    assert cond.operands[1].span == (13, 18)
    action = r.actions[0]
    assert isinstance(action, ast.Action)
    assert (action.span, action.name_span) == ((24, 34), (24, 27))


@pytest.mark.parametrize("text, start, end, message", [
    ("if sonar5 <= front arc(-2, 2)", 19, 22, "expected 'then' after the condition, found 'arc'"),
    ("if sonar5 =< 0.5 then stop()", 10, 12, "'=<' is not an operator; write '<='"),
    ("if sonar5 = 0.5 then stop()", 10, 11, "'=' is not a comparison; write '==' to compare"),
    ("if a && b then stop()", 5, 7, "'&&' is not an operator; write 'and'"),
    ("if (a < b then stop()", 3, 4, "unclosed '(': no matching ')'"),
    ("if a < b) then stop()", 8, 9, "unmatched ')'"),
    ("if a then", 9, 10,
     "expected an action such as arc(...), move(...), stop() or goto STATE, found the end of the text"),
    ("if a then arc(1 2)", 16, 17, "expected ',' or ')', found '2'"),
    ("if a then arc(1, 2) move(1)", 20, 24, "expected ',' between actions, found 'move'"),
    ("if a then goto 5", 15, 16, "expected a state name after 'goto', found '5'"),
    ("if a and then stop()", 9, 13, "expected a value or an expression, found 'then'"),
    ("sonar5 < 1 then stop()", 0, 6, "a rule starts with 'if', 'else', 'always' or 'when', not 'sonar5'"),
    ("", 0, 1, "empty rule"),
    # habits from other languages: what to write instead
    ("if a then arc(1, 2) else move(1)", 20, 24,
     "'else' starts a rule of its own: write it on the next line, as '- else move(1)'"),
    ("if a then arc(1, 2) else   goto  back", 20, 24,
     "'else' starts a rule of its own: write it on the next line, as '- else goto back'"),
    ("if a then goto follow()", 21, 22, "'goto' takes a state's name without parentheses: goto follow"),
    ('if a then print "near"', 10, 22, 'to print text, write log("near")'),
    ("if a then move 2", 15, 16,
     "expected '(' after 'move', found '2': an action takes its values in parentheses, as in move(...)"),
    ('if a then log("near %.2f" % x)', 26, 27,
     "text cannot be joined with '%': write the values in fields of the text, as in log(\"near {sonar5:.2f} m\")"),
    ('if a then log("x" + "y")', 18, 19,
     "text cannot be joined with '+': write the values in fields of the text, as in log(\"near {sonar5:.2f} m\")"),
    ('if a then log(f"x {x}")', 14, 22, "write the text without the 'f': log(\"x {x}\") fills in the {...} fields "
                                        "of its text"),
    ("if a then arc(1, 2);", 19, 20, "';' does not end or separate anything: separate actions with ','"),
    ("if a then state = follow", 16, 17, "a rule changes state with goto: write 'goto follow'"),
    ("always x = 3", 9, 10, "'=' sets nothing among a rule's actions: a value is computed under 'let:', and a "
                            "rule changes state with 'goto STATE'"),
    ("if a = 3 then stop()", 5, 6, "'=' is not a comparison; write '==' to compare"),
])
def test_rule_syntax_errors(text: str, start: int, end: int, message: str) -> None:
    with pytest.raises(ParseError) as e:
        parse_rule(text)
    assert (e.value.start, e.value.end, e.value.message) == (start, end, message)


@pytest.mark.parametrize("text, start, message", [
    ("a b", 2, "unexpected 'b': expected an operator or the end of the expression"),
    ("1 +", 3, "expected a value or an expression, found the end of the text"),
    ("a if b", 6, "expected 'else' in 'a if condition else b', found the end of the text"),
    ("a ^ 2", 2, "'^' is not an operator; write '**' for a power"),
    ("$x", 0, "unexpected character '$'"),
])
def test_expression_syntax_errors(text: str, start: int, message: str) -> None:
    with pytest.raises(ParseError) as e:
        parse_expr(text)
    assert (e.value.start, e.value.message) == (start, message)


def test_a_long_flat_sum_is_named_as_one_not_as_nesting() -> None:
    with pytest.raises(ParseError) as e:
        parse_expr(" + ".join(["sonar5"] * 101))
    assert e.value.start == 0
    assert e.value.message == "too many terms in one sum or product (labsim takes up to about 100)"
    assert isinstance(parse_expr(" + ".join(["sonar5"] * 99)), ast.Binary)
    with pytest.raises(ParseError) as e:
        parse_expr("-(" * 70 + " * ".join(["x"] * 40) + ")" * 70)
    assert e.value.message == "expression nested too deeply (more than 100 levels)"


def test_nesting_is_capped_before_anything_recursive_runs() -> None:
    with pytest.raises(ParseError) as e:
        parse_expr("-" * 1000 + "1")
    assert e.value.message == "expression nested too deeply (more than 100 levels)"
    assert parse_expr("(" * 1000 + "1" + ")" * 1000) == N(1.0)  # brackets alone nest nothing
    assert isinstance(parse_expr("-" * 90 + "1"), ast.Neg)
