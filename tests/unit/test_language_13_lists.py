"""Format 1.3's list parameters: read with their shape checked where each value is, indexed (a row, a
number of a row), counted with len(), set whole with --set; run tick by tick; refused before 1.3 and by a sweep."""
from __future__ import annotations

import math
from pathlib import Path

import pytest

from labsim.backends import load_backend
from labsim.dsl.compile import compile_file
from labsim.foundation.diagnostics import LabsimError
from labsim.runtime.run import Run

HEAD = "labsim: 1.3\nworld: walls_lab4\nstop: tick >= 5\nrobots:\n  p: {model: pioneer_p3dx, at: [0, 0, 0]}\n"
LIST = "params:\n  waypoints: [[0, -1], [3, -1], [3, -4]]\n"
RULES = "rules:\n  - always move(1)\n"
NUMBERS = ("a list's values are numbers written out, as in [0.5, 1, 2]; computed values belong under 'let:'",)


def diagnostics(path: Path, overrides: dict[str, str] | None = None) -> list[tuple[object, ...]]:
    with pytest.raises(LabsimError) as e:
        compile_file(path, overrides)
    return [(d.path, d.line, d.col, d.message, d.notes) if d.path.startswith("--set") else
            (d.line, d.col, d.message, d.notes) for d in e.value.diagnostics]


def signal_rows(path: Path, names: tuple[str, ...], overrides: dict[str, str] | None = None
                ) -> tuple[list[tuple], list[str]]:
    """Each tick's values of the signals ``names``, and the run's warnings."""
    program = compile_file(path, overrides)
    warned: list[str] = []
    run = Run(program, load_backend("pymunk"), warn=warned.append)
    rows: list[tuple] = []
    while run.tick():
        rows.append(tuple(run.robots[0].program.slots[program.slot_of[n]] for n in names))
    return rows, warned


# -- reading: the shape of a list, at the value it is about ---------------------------------------

@pytest.mark.parametrize(("value", "col", "message", "notes"), [
    ("[[0, -1], [3, -1, 2]]", 16, "row 1 of list 'w' has 3 values, and row 0 has 2: the rows of a list have one "
                                  "length", ("give every row 2 values, as row 0 has",)),
    ("[]", 6, "list 'w' is empty: a list parameter holds at least one value",
     ("e.g. waypoints: [[0, -1], [3, -1], [3, -4]], or gains: [0.5, 1, 2]",)),
    ("[[0, -1], [3, x]]", 20, "list 'w' holds numbers, not 'x'", NUMBERS),
    ("[1, true]", 10, "list 'w' holds numbers, not 'true'", NUMBERS),
    ("[1, .inf]", 10, "list 'w' holds finite numbers, not '.inf'", ()),
    ("[1, [2]]", 10, "list 'w' starts with a number, so it is a list of numbers, and this is a list in it",
     ("a list holds numbers, or rows of numbers (then every value is a row), e.g. waypoints: [[0, -1], [3, -1], "
      "[3, -4]], or gains: [0.5, 1, 2]",)),
    ("[[1], 2]", 12, "list 'w' is a list of rows, and this is not a row: write it as [a, b, ...]", ()),
    ("[[0, 1], []]", 15, "row 1 of list 'w' is empty", ()),
    ("[[[1]]]", 8, "a row of list 'w' holds numbers, and this is a list in it",
     ("a list holds numbers, or rows of numbers (then every value is a row), e.g. waypoints: [[0, -1], [3, -1], "
      "[3, -4]], or gains: [0.5, 1, 2]",)),
])
def test_a_list_of_the_wrong_shape_is_an_error_at_the_value(write, value: str, col: int, message: str,
                                                            notes: tuple[str, ...]) -> None:
    path = write(HEAD + f"params:\n  w: {value}\nlet:\n  a: len(w)\n" + RULES)
    assert diagnostics(path) == [(7, col, message, notes)]  # and its use says nothing more


def test_a_list_written_as_a_block_reads_as_one_on_a_line(write) -> None:
    path = write(HEAD + "params:\n  w:\n    - [0, -1]\n    - [3, -1]\n    - [3]\nlet:\n  a: len(w)\n" + RULES)
    assert diagnostics(path) == [(10, 7, "row 2 of list 'w' has 1 value, and row 0 has 2: the rows of a list "
                                         "have one length", ("give every row 2 values, as row 0 has",))]


def test_a_list_parameter_is_format_1_3(write) -> None:
    path = write(HEAD.replace("1.3", "1.2") + LIST + "let:\n  a: waypoints[0][0]\n" + RULES)
    assert diagnostics(path) == [(7, 14, "a list parameter is format 1.3: start the file with 'labsim: 1.3'", ())]


def test_len_is_format_1_3_and_a_files_own_len_stays(write) -> None:
    path = write(HEAD.replace("1.3", "1.2") + "let:\n  g: [sonar1, sonar2]\n  a: len(g)\n" + RULES)
    assert diagnostics(path) == [(8, 6, "len() is format 1.3: start the file with 'labsim: 1.3'", ())]
    path = write(HEAD.replace("1.3", "1.2") + "functions:\n  len(a): a * 2\nlet:\n  a: len(3)\n" + RULES)
    assert signal_rows(path, ("a",))[0][0] == (6.0,)


# -- checking: the places known before the run, and the types -----------------------------------

@pytest.mark.parametrize(("expr", "col", "message", "notes"), [
    ("waypoints[3]", 16, "list 'waypoints' has 3 rows, at places 0 to 2; not 3", ("its rows are at places 0 to 2",)),
    ("waypoints[-1][0]", 16, "list 'waypoints' has 3 rows, at places 0 to 2; not -1",
     ("its rows are at places 0 to 2",)),
    ("waypoints[0.5][0]", 16, "list 'waypoints' has 3 rows, at places 0 to 2; not 0.5",
     ("its rows are at places 0 to 2; round a fraction, as in waypoints[round(i)]",)),
    ("waypoints[len(waypoints)][1]", 16, "list 'waypoints' has 3 rows, at places 0 to 2; 'len(waypoints)' is 3",
     ("its rows are at places 0 to 2",)),
    ("waypoints[0][2]", 19, "this group has 2 members, at places 0 to 1; not 2",
     ("places count from 0: the first member is [0]",)),
    ("waypoints + 1", 6, "'+' needs a number, but this is a list of rows",
     ("pick a row with waypoints[i], a number of it with waypoints[i][0], or count the rows with len(waypoints)",)),
    ("len(3)", 10, "len() takes a list or a group, but this is a number", ()),
    ("len(waypoints, 2)", 6, "len() takes 1 argument, a list or a group, given 2", ()),
    ('waypoints["a"][0]', 16, "a row is picked by its place, a number from 0; this is text", ()),
    ("x[0]", 6, "only a group or a list has members to pick with [...]; this is a number", ()),
    ("waypoints[randint(0, 2)][0]", 16, "randint() draws a random number, but here it is paired with every member "
     "of a group, so it would run once per member", ("give it a signal of its own: 'p: randint(0, 2)', then "
                                                     "'waypoints[p]'",)),
])
def test_each_mistake_with_a_list_is_reported_at_its_place(write, expr: str, col: int, message: str,
                                                          notes: tuple[str, ...]) -> None:
    path = write(HEAD + LIST + f"let:\n  a: {expr}\n" + RULES)
    assert diagnostics(path) == [(9, col, message, notes)]


def test_a_robots_own_value_of_a_list_is_refused_with_the_way_to_do_it(write) -> None:
    path = write(HEAD.replace("at: [0, 0, 0]}", "count: 2, at: random, params: {waypoints: 1}}") + LIST + RULES)
    assert diagnostics(path) == [(5, 59, "robot 'p' sets list parameter 'waypoints': a list is the same for every "
                                         "robot", ("give each robot its own row of 'waypoints' and pick it with "
                                                   "waypoints[index]",))]


# -- running, tick by tick -----------------------------------------------------------------------

def test_rows_numbers_and_len_tick_by_tick_and_a_missing_row_is_nan_and_one_warning_a_tick(write) -> None:
    path = write(HEAD + LIST + "  gains: [0.5, 1, 2]\nlet:\n  i: tick % 4\n  here: waypoints[i]\n"
                 "  gx: here[0]\n  gy: waypoints[i][1]\n  last: waypoints[len(waypoints) - 1][1]\n  g: gains[i]\n"
                 "  doubled: sum(gains * 2)\n" + RULES)
    rows, warned = signal_rows(path, ("gx", "gy", "last", "g", "doubled"))
    nan = math.nan
    expected = [(0.0, -1.0, -4.0, 0.5, 7.0), (3.0, -1.0, -4.0, 1.0, 7.0), (3.0, -4.0, -4.0, 2.0, 7.0),
                (nan, nan, -4.0, nan, 7.0), (0.0, -1.0, -4.0, 0.5, 7.0)]
    assert [tuple("nan" if v != v else v for v in r) for r in rows] == \
        [tuple("nan" if v != v else v for v in r) for r in expected]
    assert [w.split(": warning: ")[1].split(" in ")[0] for w in warned if "no " in w] == [
        "no row at place 3 of a list of 3 rows (places count from 0)",  # here: one warning for its two values
        "no row at place 3 of a list of 3 rows (places count from 0)",  # gy
        "no member at place 3 of a group of 3 (places count from 0)"]  # g


def test_a_list_is_set_whole_and_the_set_value_is_checked_as_the_files(write) -> None:
    path = write(HEAD + LIST + "let:\n  n: len(waypoints)\n  gx: waypoints[1][0]\n" + RULES)
    rows, _ = signal_rows(path, ("n", "gx"), {"waypoints": "[[1, 2], [5.5, 6], [7, 8], [9, 10]]"})
    assert rows[0] == (4.0, 5.5)
    how = ("set it whole, as in --set waypoints='[[0, -1], [3, -1], [3, -4]]'",)
    assert diagnostics(path, {"waypoints": "3"}) == [
        ("--set waypoints=3", 0, 0, "parameter 'waypoints' is a list: give a whole list, not '3'", how)]
    assert diagnostics(path, {"waypoints": "[1, 2]"}) == [
        ("--set waypoints=[1, 2]", 0, 0, "parameter 'waypoints' is a list of rows of numbers in the file, and so "
                                         "must be its --set", how)]
    assert diagnostics(path, {"waypoints": "[[1, 2], [3]]"}) == [
        ("--set waypoints=[[1, 2], [3]]", 0, 0, "row 1 of list 'waypoints' has 1 value, and row 0 has 2: the rows "
                                                "of a list have one length",
         ("give every row 2 values, as row 0 has",))]
    assert diagnostics(path, {"waypoints": "[[1, 2]"})[0][3] == ("parameter 'waypoints': YAML syntax error: expected "
                                                               "',' or ']', but got the end of the file (while "
                                                               "parsing a flow sequence)")
    assert diagnostics(path, {"waypoints": "[[1, 1e309]]"})[0][3] == (
        "parameter 'waypoints': number too large: labsim's numbers are 64-bit floats, at most about 1.8e+308")
    # the place checked before the run is checked against the list the run takes, and named by its --set
    [got] = diagnostics(path, {"waypoints": "[[1, 2]]"})
    assert got == ("--set waypoints=[[1, 2]]", 0, 0, "list 'waypoints' has 1 row, at places 0 to 0; not 1",
                   ("its rows are at places 0 to 0", f"waypoints[1] reads it, on line 10 of {path}"))
    # rows of another length than the file's, a place a --set number puts outside the list: at the --set, once
    assert diagnostics(path, {"waypoints": "[[1, 2, 3]]"}) == [
        ("--set waypoints=[[1, 2, 3]]", 0, 0, "parameter 'waypoints' has rows of 2 numbers in the file, and so must "
                                              "its --set; these have 3", how)]
    path = write(HEAD + LIST + "  route: 0\nlet:\n  l: waypoints[route][0]\n  r: waypoints[route][1]\n" + RULES)
    assert diagnostics(path, {"route": "5"}) == [
        ("--set route=5", 0, 0, "list 'waypoints' has 3 rows, at places 0 to 2; 'route' is 5",
         ("its rows are at places 0 to 2", f"waypoints[route] reads it, on line 10 of {path}"))]


def test_a_sweep_refuses_a_list(tmp_path: Path) -> None:
    from labsim.runtime.sweep.grid import parse_setting

    with pytest.raises(LabsimError) as e:
        parse_setting("waypoints=[[0, 1], [2, 3]]")
    [d] = e.value.diagnostics
    assert d.message == "a sweep takes numbers or true/false for 'waypoints', not a list: a list parameter is not swept"
    assert d.notes == ("sweep a number that picks a row instead, as in --set route=0,1,2 with waypoints[route] in "
                       "the file; or run each list with labsim run --set",)


def test_a_file_using_no_list_generates_the_same_code_as_before(write) -> None:
    path = write(HEAD + "params: {k: 2}\nlet:\n  a: k * sonar1\n" + RULES)
    assert "_g0" not in compile_file(path).code.source


def test_a_number_of_a_row_parses_as_two_places_with_their_spans() -> None:
    from labsim.dsl.syntax import ast
    from labsim.dsl.syntax.parse import parse_expr

    e = parse_expr("waypoints[i + 1][0] - len(waypoints)")
    assert e == ast.Binary("-", ast.Index(ast.Index(ast.Name("waypoints"), ast.Binary("+", ast.Name("i"),
                                                                                         ast.Number(1.0))),
                                          ast.Number(0.0)), ast.Call("len", (ast.Name("waypoints"),)))
    assert isinstance(e, ast.Binary) and isinstance(e.left, ast.Index) and isinstance(e.left.value, ast.Index)
    assert (e.left.span, e.left.value.span, e.left.value.index.span, e.left.index.span) == ((0, 19), (0, 16),
                                                                                          (10, 15), (17, 18))
    assert isinstance(e.right, ast.Call) and (e.right.span, e.right.func_span) == ((22, 36), (22, 25))


def test_a_breakpoint_reads_a_list_and_the_wheels_the_file_reads(write) -> None:
    from labsim.dsl.watch import compile_watch

    path = write(HEAD + LIST + "let:\n  wl: wheel_left\n  gx: waypoints[tick % 3][0]\nrules:\n  - always move(2)\n")
    program = compile_file(path)
    watch = compile_watch(program, "waypoints[1][0] + wheel_left > 4 and len(waypoints) == 3")
    run = Run(program, load_backend("pymunk"), warn=lambda _: None)
    held = []
    while run.tick():
        robot = run.robots[0].program
        held.append(watch.holds(run.tick_index - 1, program.dt_s, [], robot.slots))
    assert held[:3] == [False, True, True]  # 3 + 0 on the first tick, 3 + 2 after
    with pytest.raises(LabsimError) as e:
        compile_watch(program, "waypoints[5][0] > 1")
    assert e.value.diagnostics[0].message == "list 'waypoints' has 3 rows, at places 0 to 2; not 5"


def test_the_trace_header_records_the_lists_as_set(write, tmp_path: Path) -> None:
    import json

    path = write(HEAD + LIST + RULES)
    program = compile_file(path, {"waypoints": "[[1, 2.5]]"})
    Run(program, load_backend("pymunk"), trace_path=tmp_path / "t.csv", warn=lambda _: None).run()
    header = json.loads((tmp_path / "t.csv").read_text().splitlines()[0].removeprefix("# labsim-trace "))
    assert header["lists"] == {"waypoints": [[1.0, 2.5]]}
    Run(compile_file(write(HEAD + RULES)), load_backend("pymunk"), trace_path=tmp_path / "u.csv",
        warn=lambda _: None).run()
    assert '"lists"' not in (tmp_path / "u.csv").read_text().splitlines()[0]


def test_a_list_for_each_robot_is_refused_with_the_way_to_do_it(write) -> None:
    path = write(HEAD.replace("at: [0, 0, 0]}", "count: 2, at: random, params: {waypoints: [[1, 2], [3, 4]]}}")
                 + LIST + RULES)
    assert diagnostics(path) == [(5, 71, "robot 'p' gives 'waypoints' a list: a robot's own value is a number or "
                                         "true/false", ("for a list per robot, give the file a list parameter of rows "
                                                        "and pick each robot's with waypoints[index] (format 1.3)",))]


def test_the_outline_of_an_editor_declares_a_list_with_its_text() -> None:
    from labsim.runtime.lsp.outline import outline

    out = outline(HEAD + LIST + RULES)
    assert out is not None
    [d] = out.definitions["waypoints"]
    assert (d.kind, d.text) == ("param", "[[0, -1], [3, -1], [3, -4]]")


@pytest.mark.parametrize("count", [1, 2])
def test_a_missing_row_is_counted_once_a_tick_however_many_values_it_has(write, count: int) -> None:
    at = "at: [0, 0, 0]}" if count == 1 else "count: 2, at: [[0, 0, 0], [2, 2, 0]]}"
    path = write(HEAD.replace("tick >= 5", "tick >= 10").replace("at: [0, 0, 0]}", at) + LIST
                 + "let:\n  s: sum(waypoints[tick + 1])\nrules:\n  - if waypoints[tick + 1][1] > 9 then move(1)\n"
                 "  - else move(2)\n")
    run = Run(compile_file(path), load_backend("pymunk"), warn=lambda _: None)
    run.run()
    counts = sorted((site.where, n) for (site, _), n in run.faults.counts.items())
    # each robot: the rule on ticks 2 to 9, the signal on the stopping tick 10 too
    assert counts == [("rule main:1", 8 * count), ("signal 's'", 9 * count)]


def test_a_list_of_numbers_and_a_row_hold_as_many_as_a_group_and_a_list_ten_thousand(write) -> None:
    many = ", ".join(["1"] * 1001)
    path = write(HEAD + f"params:\n  g: [{many}]\n" + RULES)
    assert diagnostics(path) == [(7, 6, "list 'g' holds 1,001 numbers, and a list of numbers (a group) at most 1,000",
                                  ("a longer table is a list of rows, as in [[x, y], ...]",))]
    path = write(HEAD + f"params:\n  w: [[{many}]]\n" + RULES)
    assert diagnostics(path) == [(7, 7, "row 0 of list 'w' has 1,001 values, and a row (a group) at most 1,000", ())]
    rows = ", ".join(["[1, 2, 3, 4]"] * 2501)
    path = write(HEAD + f"params:\n  w: [{rows}]\n" + RULES)
    assert diagnostics(path) == [(7, 6, "list 'w' holds 10,004 numbers, more than the 10,000 a list may", ())]
    thousand = ", ".join(["2"] * 1000)
    path = write(HEAD + f"params:\n  g: [{thousand}]\n  w: [[{thousand}], [{thousand}]]\nlet:\n"
                 "  s: sum(g) + min(w[tick % 2]) + count(w[tick % 3] > 1)\n" + RULES)
    # 2,000 + 2 + 1,000 members over 1; on tick 2 there is no row 2: its members are nan, none over 1
    assert signal_rows(path, ("s",))[0][:3] == [(3002.0,), (3002.0,), (2002.0,)]


def test_a_list_read_while_running_is_bound_once_not_written_at_each_read(write) -> None:
    rows = ", ".join(f"[{i}, {-i}, {i / 4}, 7]" for i in range(2500))  # 10,000 numbers, the most a list holds
    reads = " + ".join(f"w[(tick + {j}) % 2500][{j % 4}]" for j in range(40))
    path = write(HEAD.replace("tick >= 5", "tick >= 2") + f"params:\n  w: [{rows}]\n  g: [1, 2, 3]\nlet:\n"
                 f"  a: {reads}\n  b: g[tick % 3] + g[tick % 2]\n" + RULES)
    code = compile_file(path).code
    # each column once, as a tuple make() binds; the numbers of a row appear nowhere in the source
    assert [len(c) for c in code.columns] == [2500, 2500, 2500, 2500, 3]
    assert "1249.0" not in code.source and len(code.source) < 20_000
    expected = [sum((t + j) % 2500 * (1, -1, 0.25, 0)[j % 4] + 7 * (j % 4 == 3) for j in range(40)) for t in range(2)]
    assert signal_rows(path, ("a", "b"))[0] == [(float(a), float(b)) for a, b in zip(expected, (2, 4))]


def test_a_condition_on_a_lists_length_or_values_is_known_before_the_run(write) -> None:
    path = write(HEAD.replace("stop: tick >= 5", "stop: len(g) < 1") + "params:\n  g: [1, 2]\n" + RULES)
    assert diagnostics(path) == [(3, 7, "the stop condition never holds (it is always false): the run would never end",
                                  ("e.g. 'stop: time >= 60' ends the run after a simulated minute",))]
    path = write(HEAD + LIST + "  g: [1, 2]\nrules:\n  - if g[0] > 5 then move(4)\n"
                 "  - if waypoints[2][1] < -3 and len(g) > 1 then move(3)\n  - else move(2)\n")
    assert [(d.line, d.col, d.message) for d in compile_file(path).warnings] == [
        (10, 8, "this condition never holds: the rule never fires"),
        (12, 5, "this rule can never fire: the condition of the rule on line 11 always holds, and that rule fires "
                "first")]


def test_the_summary_and_its_json_show_the_lists_as_set_starred_and_a_long_one_shortened(write) -> None:
    from labsim.runtime.cli.report import format_summary
    from labsim.runtime.summary_json import summary_dict

    long = ", ".join(f"[{i}, {-i / 2}]" for i in range(40))
    path = write(HEAD + LIST + f"  long: [{long}]\n  gains: [0.5, 1, 2]\n  k: 2\n" + RULES)
    result = Run(compile_file(path, {"waypoints": "[[1, 2.5]]"}), load_backend("pymunk"), warn=lambda _: None).run()
    [line] = [line for line in format_summary(result).splitlines() if line.startswith("  params:")]
    assert line == ("  params: k=2 waypoints=[[1, 2.5]]* long=[[0, 0], [1, -0.5], [2, -1], [3, -1.5], ... 40 rows] "
                    "gains=[0.5, 1, 2]   (* set on the command line)")
    data = summary_dict(result)
    assert (data["params"], data["overridden"]) == ({"k": 2.0}, ["waypoints"])
    assert data["lists"]["waypoints"] == [[1.0, 2.5]] and data["lists"]["gains"] == [0.5, 1.0, 2.0]
    assert len(data["lists"]["long"]) == 40


def test_a_place_a_hair_from_a_whole_number_is_shown_in_full(write) -> None:
    path = write(HEAD + LIST + "  k: 2.9999999999999996\nlet:\n  b: waypoints[k][0]\n" + RULES)
    assert diagnostics(path) == [(10, 16, "list 'waypoints' has 3 rows, at places 0 to 2; 'k' is 2.9999999999999996",
                                  ("its rows are at places 0 to 2; round a fraction, as in waypoints[round(i)]",))]
    path = write(HEAD + LIST + "  g: [1, 2, 3]\nlet:\n  a: waypoints[(tick * 0 + 0.1 + 0.2) * 10][0]\n"
                 "  b: g[tick * 0 + 1 / 3]\n" + RULES)
    _, warned = signal_rows(path, ("a", "b"))
    assert [w.split(": warning: ")[1].split(" in ")[0] for w in warned if "no " in w][:2] == [
        "no row at place 3.0000000000000004 of a list of 3 rows (places count from 0)",
        "no member at place 0.333333 of a group of 3 (places count from 0)"]  # no whole place to mistake it for


def test_noise_naming_a_list_says_it_is_a_list_and_an_unused_list_warns_as_a_number_does(write) -> None:
    path = write(HEAD.replace("at: [0, 0, 0]}", "at: [0, 0, 0], noise: {sonar: {std_m: g}}}")
                 + "params:\n  g: [0.1, 0.2]\nrules:\n  - always move(g[0])\n")
    assert diagnostics(path) == [(5, 66, "sonar noise std_m must be a number, and parameter 'g' is a list",
                                  ("name a parameter that is one number, or write the number",))]
    path = write(HEAD + LIST + "  g: [1, 2]\n  k: 2\n" + RULES)
    assert [(d.line, d.col, d.message) for d in compile_file(path).warnings] == [
        (7, 14, "parameter 'waypoints' is never used"), (8, 6, "parameter 'g' is never used"),
        (9, 6, "parameter 'k' is never used")]


def test_a_table_written_in_a_signal_is_told_to_be_a_list_parameter(write) -> None:
    path = write(HEAD + "let:\n  m: [[1, 2], [3, -4]]\n  g: [[1, 2], [sonar1, 4]]\n" + RULES)
    note = ("a table of numbers is a list parameter (format 1.3): put it under 'params:', as in 'params: {waypoints: "
            "[[0, -1], [3, -1]]}'",)
    message = "a group's members are all numbers or all booleans; this one is a group of numbers"
    assert diagnostics(path) == [(7, 7, message, note), (8, 7, message, ())]


def test_a_fraction_without_its_leading_0_is_a_number_wherever_a_number_is_read(write) -> None:
    path = write(HEAD.replace("at: [0, 0, 0]}", "at: [-.5, .5e1, +.5]}") + "params:\n  a: -.5\n  b: .5e1\n"
                 "  g: [-.5, .5e1, .25]\n  q: '-.5'\nlet:\n  s: a + b + sum(g) + q\n" + RULES)
    assert diagnostics(path) == [(10, 6, "parameter 'q' must be a number or true/false, not '-.5'",
                                  ("computed values belong under 'let:'",))]  # quoted: text, as '0.5' is
    program = compile_file(write(HEAD.replace("at: [0, 0, 0]}", "at: [-.5, .5e1, +.5]}") + "params:\n  a: -.5\n"
                                 "  b: .5e1\n  g: [-.5, .5e1, .25]\nlet:\n  s: a + b + sum(g)\n" + RULES))
    assert (program.params["a"], program.params["b"], program.lists["g"]) == (-0.5, 5.0, (-0.5, 5.0, 0.25))
    pose = program.starts[0].pose
    assert (pose.x_m, pose.y_m, pose.heading_rad) == (-0.5, 5.0, math.radians(0.5))


def test_a_row_each_robot_picks_by_its_index_is_checked_for_every_robot(write) -> None:
    path = write(HEAD.replace("at: [0, 0, 0]}", "count: 2, at: random}\n  q: {model: pioneer_p3dx, count: 4, "
                              "at: random}") + LIST + "  g: [1, 2, 3, 4]\nlet:\n  a: waypoints[index][0]\n"
                 "  b: g[index] + waypoints[min(index, 2)][1]\n" + RULES)
    assert diagnostics(path) == [(11, 16, "list 'waypoints' has 3 rows, at places 0 to 2; 'index' is 3 for robot q[3]",
                                  ("its rows are at places 0 to 2", "each robot picks the row at its own place: give "
                                                                    "the list a row for every robot"))]
