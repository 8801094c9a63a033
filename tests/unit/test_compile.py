"""The compiler: generated code computes what the language says, faults are defined, and the
program it hands the runtime is sealed and readable."""
from __future__ import annotations

import dataclasses
import linecache
import math
import random
import re
import traceback
from collections.abc import Mapping

import pytest
import yaml
from helpers import BEHAVIOURS, FIXTURES

import labsim.dsl.emit.program
from labsim.dsl.analysis.check import Checked
from labsim.dsl.compile import compile_file
from labsim.dsl.library.support import FIRST_CHANNEL, Faults
from labsim.dsl.syntax.read import BehaviourFile, Parsed
from labsim.foundation.source import Document, Text
from labsim.runtime.cli.main import main


def program(write, lets: str, params: str = "{}", stop: str = "time >= 1"):
    path = write(f"labsim: 1\nworld: walls_lab4\nstop: {stop}\nrobots:\n  p: {{model: pioneer_p3dx}}\n"
                 f"params: {params}\nlet:\n{lets}\nrules:\n  - always stop()\n")
    return compile_file(path)


def evaluate(write, expr: str, params: str = "{a: 3, flag: true}"):
    """The value of `expr` as a signal (sonar1 0.5 m, sonar2 2 m, sonar3 sees nothing) and the warnings."""
    p = program(write, f"  probe: {expr}\n  keep: sonar1 + sonar2 + sonar3\n", params)
    warnings: list[str] = []
    robot = p.robot("p", random.Random(0), Faults(warnings.append))
    values = [{"sonar1": 0.5, "sonar2": 2.0, "sonar3": math.inf}[c] for c in p.channels]
    robot.signals(0.0, 0, values)
    return robot.slots[p.slot_of["probe"]], warnings


@pytest.mark.parametrize("expr, value", [
    ("1 + 2 * 3", 7.0),
    ("-2 ** 2", -4.0),
    ("7 % 3", 1.0),
    ("a * sonar1", 1.5),
    ("0.3 < sonar1 <= 1", True),
    ("0.3 < sonar2 <= 1", False),
    ("sonar1 < 1 and not flag", False),
    ("sonar1 < 1 or flag", True),
    ("sonar1 if flag else sonar2", 0.5),
    ("min(sonar1, sonar2, a)", 0.5),
    ("max(sonar1, sonar2)", 2.0),
    ("clamp(sonar2, 0, 1)", 1.0),
    ("abs(-sonar2)", 2.0),
    ("hypot(3, 4)", 5.0),
    ("deg(pi)", 180.0),
    ("sign(-sonar1)", -1),
    ("detected(sonar1)", True),
    ("detected(sonar3)", False),
    ("sonar3", math.inf),
    ("round(2.5) + floor(sonar2 + 0.5)", 4.0),
    ("floor(-sonar3)", -math.inf),
    ("-sign(sonar1 - 0.5)", -0.0),
])
def test_expressions(write, expr: str, value: object) -> None:
    got, warnings = evaluate(write, expr)
    assert got == value
    assert warnings == []


@pytest.mark.parametrize("expr, value, fault", [
    ("sonar1 / (sonar1 - 0.5)", math.inf, "division by zero"),
    ("-sonar1 / (sonar1 - 0.5)", -math.inf, "division by zero"),
    ("(sonar1 - 0.5) / (sonar1 - 0.5)", math.nan, "division by zero"),
    ("sonar2 % (sonar1 - 0.5)", math.nan, "modulo by zero"),
    ("sqrt(-sonar1)", math.nan, "sqrt(): math domain error"),
    ("log(sonar1 - 0.5)", -math.inf, None),
    ("(-sonar1) ** 0.5", math.nan, "a negative number to a fractional power"),
    ("10 ** (sonar2 * 400)", math.inf, "overflow in '**'"),
    ("(-10) ** (sonar2 * 200 + 1)", -math.inf, "overflow in '**'"),
    ("(-sonar1 * 1e-300) ** -2.5", math.nan, "a negative number to a fractional power"),
    ("(sonar3 - sonar3) / (sonar1 - 0.5)", math.nan, "division by zero"),
    ("randint(sonar2, sonar1)", math.nan, "randint(): randint(2, 0.5) has no integer between its bounds"),
])
def test_faults_have_defined_results_and_warn_once(write, expr: str, value: float, fault: str | None) -> None:
    got, warnings = evaluate(write, expr)
    assert got == value or (math.isnan(value) and math.isnan(got))
    if fault is None:
        assert warnings == []
    else:
        (w,) = warnings
        assert f"warning: {fault} in signal 'probe', robot p, tick 0" in w
        assert "  probe: " in w and "^" in w  # the source line and a caret under the expression


@pytest.mark.parametrize("expr", [
    "min(sqrt(-sonar1), 1)", "min(1, sqrt(-sonar1))", "min(1, 2, sqrt(-sonar1))",
    "max(sqrt(-sonar1), 1)", "max(1, sqrt(-sonar1))", "max(sonar3, 2, sqrt(-sonar1))",
])
def test_min_and_max_of_a_nan_are_nan_wherever_it_stands(write, expr: str) -> None:
    got, warnings = evaluate(write, expr)
    assert math.isnan(got) and len(warnings) == 1  # the sqrt's warning, nothing more


@pytest.mark.parametrize("expr, value", [
    ("min(sonar3, 1)", 1.0), ("max(sonar3, 1)", math.inf), ("min(-sonar3, sonar3)", -math.inf),
    ("min(2, 1, 3)", 1.0), ("max(2, 1, 3)", 3.0), ("min(0, 1)", 0.0), ("max(-1, 0)", 0.0),
])
def test_min_and_max_with_infinities_and_folded(write, expr: str, value: float) -> None:
    got, warnings = evaluate(write, expr)
    assert got == value and warnings == []


def test_constants_are_folded(write) -> None:
    p = program(write, "  scaled: sonar1 * (a * 60)\n", params="{a: 25}", stop="time >= a * 60")
    source = p.code.source
    assert "return (v0 >= 1500.0)" in source
    assert "(v3 * 1500.0)" in source


def test_no_user_text_reaches_the_generated_code(write) -> None:
    p = program(write, "  __import__: sonar1\n  open_file: __import__ + 1\n", params="{system: 2}")
    source = p.code.source
    for word in ("__import__", "open_file", "system", "sonar1"):
        assert word not in source
    # everything in it comes from a fixed vocabulary: slots, literals, operators, bound helpers
    assert set(re.findall(r"[A-Za-z_][A-Za-z_0-9]*", source)) <= {
        "def", "make", "signals", "decide", "both", "fold", "None", "return", "if", "elif", "else", "and", "or", "not",
        "s", "cmd", "jc", "events", "m", "v", "rule", "values", "True", "False", "append",
    } | {w for w in re.findall(r"[A-Za-z_][A-Za-z_0-9]*", source) if re.fullmatch(r"(v\d+|_[a-z0-9_]+)", w)}


def test_each_robot_has_its_own_random_stream_and_slots(write) -> None:
    p = program(write, "  r: randint(0, 1000000)\n")
    a = p.robot("a", random.Random("1/a"), Faults())
    b = p.robot("b", random.Random("1/b"), Faults())
    a2 = p.robot("a", random.Random("1/a"), Faults())
    draws = []
    for robot in (a, b, a2):
        robot.signals(0.0, 0, [])
        draws.append(robot.slots[FIRST_CHANNEL])
    assert draws[0] == draws[2] != draws[1]


def test_the_program_cannot_be_changed(write) -> None:
    p = program(write, "  probe: sonar1\n", params="{a: 3}")
    with pytest.raises(dataclasses.FrozenInstanceError):
        p.seed = 2  # type: ignore[misc]
    with pytest.raises(dataclasses.FrozenInstanceError):
        p.code = p.code  # type: ignore[misc]
    for mapping in (p.params, p.slot_of, p.models, p.channel_kinds, p.signal_types, p.slider_ranges):
        with pytest.raises(TypeError):
            mapping["a"] = 1  # type: ignore[index]
    assert all(isinstance(getattr(p, f.name), (tuple, str, int, float, bool, Mapping, type(None)))
               or f.name in ("world", "code") for f in dataclasses.fields(p))


def test_nothing_of_the_file_or_the_front_end_is_reachable_from_the_program() -> None:
    p = compile_file(BEHAVIOURS / "wall_follow.yaml")
    front_end = (yaml.Node, Document, Text, Parsed, BehaviourFile, Checked)
    seen: set[int] = set()
    todo: list[object] = [p]
    while todo:
        value = todo.pop()
        if id(value) in seen or isinstance(value, (str, int, float, bool, type(None))):
            continue
        seen.add(id(value))
        assert not isinstance(value, front_end), f"{type(value).__name__} reachable from the program"
        if dataclasses.is_dataclass(value):
            todo += [getattr(value, f.name) for f in dataclasses.fields(value)]
        elif isinstance(value, Mapping):
            todo += [*value.keys(), *value.values()]
        elif isinstance(value, (tuple, list, set, frozenset)):
            todo += list(value)


def test_show_code_prints_each_rule_signal_and_metric_under_its_file_line(capsys) -> None:
    path = BEHAVIOURS / "wall_follow.yaml"
    assert main(["check", "--show-code", str(path)]) == 0
    out = capsys.readouterr().out
    lines = out.splitlines()
    p = compile_file(path)
    for rule in p.rules:
        comment = f"# {path}:{rule.line}: rule {rule.id}: {rule.text}"
        (i,) = [i for i, line in enumerate(lines) if line.strip() == comment][:1]
        assert re.match(r" *(if|elif|else)\b", lines[i + 1]), lines[i + 1]  # the rule's own test follows
    assert (f"# {path}:38: rule wander:1: if ahead <= front or sonar8 <= front or sonar15 <= front or "
            "min(sonar9, sonar14) <= back then goto follow") in out
    assert f"# {path}:27: ahead: min(sonar5, sonar2)" in out
    assert f"# {path}:51: near_misses: count(min(ahead, right, left) < 0.25)" in out
    assert f"# {path}:14: stop: time >= minutes * 60" in out
    compile(out, "listing", "exec")  # it is Python
    # the listing is the compiled source with its markers explained, line for line
    assert out == p.code.listing + "\n" and len(lines) == len(p.code.source.splitlines()) + 1


def test_each_generated_line_knows_the_file_line_it_comes_from() -> None:
    p = compile_file(BEHAVIOURS / "wall_follow.yaml")
    source = p.code.source.splitlines()
    assert len(p.code.marks) == len(source)
    marks = dict(zip((line.strip() for line in source), p.code.marks))
    assert marks["elif (v5 <= 0.3):"] == 42 and marks["cmd[0] = 1.0"] == 42  # rule follow:2 and its action
    assert marks["s[11] = v11 = (_nan if v4 != v4 or v3 != v3 else (v3 if v3 < v4 else v4))"] == 27  # ahead
    assert marks["return (v0 >= 1500.0)"] == 14 and marks["m[0][0] += 1"] == 51  # the stop condition, a metric
    assert marks["def decide():"] == marks["v2 = s[2]"] == marks["rule = -1"] == 0  # plumbing
    assert {p.code.marks[i] for i, line in enumerate(source) if line.startswith("#")} == {0}  # the header


def test_show_code_on_a_file_with_errors_reports_them(capsys) -> None:
    assert main(["check", "--show-code", str(FIXTURES / "unknown_sensor_with_error.yaml")]) == 2
    out, err = capsys.readouterr()
    assert "def make(" not in out and "unknown name 'sonr5'" in err


def test_a_traceback_through_generated_code_shows_the_generated_line(write, monkeypatch) -> None:
    def broken_guard(*args: object) -> object:
        def fail(*values: object) -> object:
            raise RuntimeError("a guard that breaks")
        return fail

    p = program(write, "  probe: sqrt(sonar1) + 1\n")
    monkeypatch.setattr(labsim.dsl.emit.program, "guard", broken_guard)
    robot = p.robot("p", random.Random(0), Faults())
    with pytest.raises(RuntimeError):
        try:
            robot.signals(0.0, 0, [0.5])
        except RuntimeError:
            text = traceback.format_exc()
            raise
    assert p.code.filename == f"<labsim {p.path}>"
    (line,) = re.findall(rf'File "{re.escape(p.code.filename)}", line (\d+), in signals', text)
    generated = linecache.getline(p.code.filename, int(line))
    assert generated.strip() == "s[4] = v4 = (_g0(v3) + 1.0)"
    assert "    s[4] = v4 = (_g0(v3) + 1.0)" in text  # shown under its frame
    assert linecache.getline(p.code.filename, int(line) - 1).strip() == f"# {p.path}:8: probe: sqrt(sonar1) + 1"
