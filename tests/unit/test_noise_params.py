"""Noise numbers written as parameters (format 1.2): read, resolved after --set and per member,
checked against each key's range at its place, and shown resolved in the trace and summary."""
from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
from helpers import FIXTURES

from labsim.backends import load_backend
from labsim.dsl.compile import compile_file
from labsim.dsl.syntax.noise import Noise
from labsim.foundation.diagnostics import LabsimError
from labsim.runtime.cli.main import main
from labsim.runtime.cli.report import format_summary
from labsim.runtime.run import compile_behaviour
from labsim.runtime.trace import read_trace

# A robot 0.75 m from the east wall, facing it, standing still: sonar5 sees the wall every tick.
STILL = """\
labsim: {version}
world: walls_lab4
seed: 1
stop: time >= 2
params:
  drop: 0.5
  jitter: 0.01
robots:
  pioneer:
    model: pioneer_p3dx
    at: [6.5, 0, 0]
{own}    noise:
      sonar: {{std_m: jitter, dropout: drop}}
let:
  ahead: sonar5
rules:
  - always move(0)
"""


def _file(write, version: str = "1.2", own: str = "", name: str = "b.yaml") -> Path:
    return write(STILL.format(version=version, own=own), name)


def errors(path: Path, overrides: dict[str, str] | None = None) -> list[str]:
    with pytest.raises(LabsimError) as e:
        compile_file(path, overrides)
    return [d.format().splitlines()[0].removeprefix(f"{path}:") for d in e.value.diagnostics
            if d.severity == "error"]


def test_a_parameter_gives_the_noise_and_set_changes_it(write) -> None:
    path = _file(write)
    program = compile_file(path)
    assert program.robots[0].noise == Noise(sonar_std_m=0.01, sonar_dropout=0.5)
    assert compile_file(path, {"drop": "0.1"}).robots[0].noise == Noise(sonar_std_m=0.01, sonar_dropout=0.1)
    assert compile_file(path, {"drop": "0", "jitter": "0"}).robots[0].noise is None  # 0 everywhere: none
    # used only by the noise, the parameters are used: no warning
    assert not [w.message for w in program.warnings if "never used" in w.message]


def test_the_range_is_checked_on_the_value_after_set_at_the_noise_key(write) -> None:
    path = _file(write)
    assert errors(path, {"drop": "1.5"}) == [
        "13:39: error: sonar noise dropout must be between 0 and 1, not 1.5 (parameter 'drop', from --set drop=1.5)"]
    assert errors(path, {"jitter": "-1"}) == [
        "13:22: error: sonar noise std_m must be between 0 and 10, not -1 (parameter 'jitter', from --set jitter=-1)"]


def test_the_error_fixture_reports_names_types_and_ranges(write) -> None:
    """tests/unit/test_check.py holds it to its '# expect:' lines; here, what its notes say."""
    with pytest.raises(LabsimError) as e:
        compile_file(FIXTURES / "noise_params_with_error.yaml")
    notes = {d.message: d.notes for d in e.value.diagnostics}
    assert notes["unknown parameter 'jiter' (did you mean 'jitter'?)"] == ("parameters: drop, jitter, flag",)
    assert notes["unknown parameter 'ghost'"] == ("parameters: drop, jitter, flag",)


def test_without_params_an_unknown_name_says_how_to_declare_it(write) -> None:
    path = write(STILL.format(version="1.2", own="").replace("params:\n  drop: 0.5\n  jitter: 0.01\n", ""))
    with pytest.raises(LabsimError) as e:
        compile_file(path)
    found = sorted((d.line, d.col, d.message, d.notes) for d in e.value.diagnostics)
    hint = "declare it under 'params:', e.g. params: {{{}: 0.1}}"
    assert found == [(10, 22, "unknown parameter 'jitter'", (hint.format("jitter"),)),
                     (10, 39, "unknown parameter 'drop'", (hint.format("drop"),))]


def test_a_word_that_is_no_name_and_a_version_1_1_file(write) -> None:
    bad = write(STILL.format(version="1.2", own="").replace("dropout: drop", "dropout: drop * 2"))
    assert errors(bad) == ["13:39: error: sonar noise dropout must be a number or the name of a parameter, "
                           "not 'drop * 2'"]
    # a 1.1 file keeps its meaning: a word is no number, and the note says which version takes it
    old = _file(write, version="1.1", name="old.yaml")
    with pytest.raises(LabsimError) as e:
        compile_file(old)
    found = sorted((d.line, d.col, d.message) for d in e.value.diagnostics if d.severity == "error")
    assert found == [(13, 22, "sonar noise std_m must be a number, not 'jitter'"),
                     (13, 39, "sonar noise dropout must be a number, not 'drop'")]
    assert all("labsim: 1.2" in d.notes[0] for d in e.value.diagnostics if d.severity == "error")


def test_a_groups_own_values_give_each_member_its_noise(write) -> None:
    own = "    count: 3\n    at: random\n    params: {drop: [0, 1, 0.25]}\n"
    path = write(STILL.format(version="1.2", own=own).replace("    at: [6.5, 0, 0]\n", ""))
    group = compile_file(path, {"drop": "0.9"}).robots[0]  # the group's own values win, as in expressions
    assert group.noise is None
    assert [group.noise_of(k) for k in range(3)] == [Noise(sonar_std_m=0.01), Noise(sonar_std_m=0.01, sonar_dropout=1),
                                                     Noise(sonar_std_m=0.01, sonar_dropout=0.25)]
    run = compile_behaviour(path).bind(load_backend("pymunk"), trace=path.with_suffix(".csv"))
    try:
        text = format_summary(run.run())
    finally:
        run.close()
    header = json.loads(path.with_suffix(".csv").read_text().split("\n", 1)[0].removeprefix("# labsim-trace "))
    assert header["noise"] == {"pioneer[0]": {"sonar": {"std_m": 0.01}},
                               "pioneer[1]": {"sonar": {"std_m": 0.01, "dropout": 1.0}},
                               "pioneer[2]": {"sonar": {"std_m": 0.01, "dropout": 0.25}}}
    assert "noise: pioneer[1]: sonar 0.01 m, 100% dropout (41 sonar readings lost)" in text
    # one value for every member: one noise for the group
    same = write(STILL.format(version="1.2", own="    params: {drop: 0.2}\n"), "same.yaml")
    group = compile_file(same).robots[0]
    assert group.noise == Noise(sonar_std_m=0.01, sonar_dropout=0.2) and group.member_noise == ()


def _run(path: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], *options: str) -> tuple[list[float], dict]:
    trace = tmp_path / "t.csv"
    assert main(["run", str(path), "-q", "--json", "--trace", str(trace), *options]) == 0
    summary = json.loads(capsys.readouterr().out)
    return [float(v) for v in read_trace(trace).column("ahead")], summary


def test_set_on_the_command_line_changes_what_the_robot_reads(write, tmp_path: Path,
                                                              capsys: pytest.CaptureFixture[str]) -> None:
    path = _file(write)
    lost, summary = _run(path, tmp_path, capsys, "--set", "drop=1")
    assert lost and all(v == math.inf for v in lost)  # every reading lost
    assert summary["robots"]["pioneer"]["noise"] == {"sonar": {"std_m": 0.01, "dropout": 1.0}}
    assert summary["robots"]["pioneer"]["sonar_readings_lost"] == len(lost)
    kept, summary = _run(path, tmp_path, capsys, "--set", "drop=0", "--set", "jitter=0")
    assert len(set(kept)) == 1 and math.isfinite(kept[0])  # none lost, no jitter: the wall, every tick
    assert summary["robots"]["pioneer"]["noise"] == {}
    half, _ = _run(path, tmp_path, capsys)
    assert 0 < sum(v == math.inf for v in half) < len(half)
    assert main(["run", str(path), "-q", "--set", "drop=2"]) == 2
    assert ":13:39: error: sonar noise dropout must be between 0 and 1, not 2 (parameter 'drop', from --set drop=2)" \
        in capsys.readouterr().err


def test_a_file_without_parameters_in_its_noise_has_the_noise_it_had(write) -> None:
    literal = write(STILL.format(version="1.2", own="").replace("std_m: jitter, dropout: drop",
                                                                 "std_m: 0.01, dropout: 0.5"), "literal.yaml")
    named = _file(write, name="named.yaml")
    traces = []
    for path in (literal, named):
        run = compile_behaviour(path).bind(load_backend("pymunk"), trace=path.with_suffix(".csv"))
        try:
            run.run()
        finally:
            run.close()
        traces.append(path.with_suffix(".csv").read_text().split("\n", 1))
    assert traces[0][1] == traces[1][1]  # the same rows
    assert json.loads(traces[0][0].removeprefix("# labsim-trace "))["noise"] == \
        json.loads(traces[1][0].removeprefix("# labsim-trace "))["noise"]


def test_the_schema_takes_a_number_or_a_parameter_name() -> None:
    jsonschema = pytest.importorskip("jsonschema")
    from labsim.dsl.syntax.schema import behaviour_schema

    validator = jsonschema.Draft7Validator(behaviour_schema())
    base = {"labsim": 1.2, "world": "walls_lab4", "stop": "time >= 1", "rules": ["always move(1)"]}

    def valid(dropout: object) -> bool:
        robots = {"pioneer": {"model": "pioneer_p3dx", "noise": {"sonar": {"dropout": dropout}}}}
        return not list(validator.iter_errors({**base, "robots": robots}))

    assert valid(0.1) and valid("drop")
    assert not valid(2) and not valid("drop * 2") and not valid(True)
