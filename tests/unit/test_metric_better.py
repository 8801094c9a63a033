"""Which way a metric is better: ``better:`` as declared, each aggregate's default, and where the
direction is recorded (the Program, the result, the JSON summary, the trace header). The checker's
messages for a wrong ``better:`` are in tests/fixtures/metric_better_with_error.yaml."""
from __future__ import annotations

import json
from pathlib import Path

from helpers import BEHAVIOURS

from labsim.backends import load_backend
from labsim.dsl.compile import compile_file
from labsim.dsl.library.builtins import Aggregate, Better, Type
from labsim.runtime.run import Run
from labsim.runtime.summary_json import summary_dict
from labsim.runtime.trace import read_trace

HEAD = ("labsim: 1\nworld: walls_lab4\nstop: time >= 1\nrobots:\n  p: {model: pioneer_p3dx, at: [0, 0, 0]}\n"
        "rules:\n  - always move(1)\n")


def test_each_aggregate_has_its_default_direction(write) -> None:
    argument = {Type.BOOL: "sonar5 < 1", Type.NUMBER: "sonar5"}
    path = write(HEAD + "metrics:\n" + "".join(f"  m_{a.value}: {a.value}({argument[a.argument]})\n"
                                               for a in Aggregate))
    program = compile_file(path)
    assert dict(zip(program.metric_aggregates, program.metric_better)) == {
        Aggregate.COUNT: Better.LOWER, Aggregate.MEAN: Better.LOWER, Aggregate.RMS: Better.LOWER,
        Aggregate.MAXIMUM: Better.LOWER, Aggregate.MINIMUM: Better.HIGHER, Aggregate.FINAL: Better.HIGHER,
        Aggregate.DURATION: None,
    }


def test_a_declared_direction_wins_and_the_plain_form_still_reads(write) -> None:
    path = write(HEAD + "metrics:\n  busy: {value: duration(sonar5 < 1), better: higher}\n"
                        "  speed:\n    value: mean(sonar5)\n    better: higher\n"
                        "  low: {value: minimum(sonar5), better: lower}\n  plain: count(sonar5 < 1)\n")
    program = compile_file(path)
    assert program.metric_names == ("busy", "speed", "low", "plain")
    assert program.metric_better == (Better.HIGHER, Better.HIGHER, Better.LOWER, Better.LOWER)


def test_the_direction_is_in_the_result_the_json_summary_and_the_trace_header(write, tmp_path: Path) -> None:
    path = write(HEAD + "metrics:\n  busy: {value: duration(sonar5 < 1), better: higher}\n  idle: duration(true)\n"
                        "  hits: count(sonar5 < 1)\n")
    trace = tmp_path / "t.csv"
    result = Run(compile_file(path), load_backend("pymunk"), trace_path=trace).run()
    assert result.metric_better == {"busy": Better.HIGHER, "idle": None, "hits": Better.LOWER}
    summary = json.loads(json.dumps(summary_dict(result)))
    assert summary["metric_better"] == {"busy": "higher", "idle": None, "hits": "lower"}
    assert read_trace(trace).header["metric_better"] == {"busy": "higher", "idle": None, "hits": "lower"}


def test_a_trace_header_names_directions_only_when_one_is_not_the_default(write, tmp_path: Path) -> None:
    path = write(HEAD + "metrics:\n  idle: duration(true)\n  hits: {value: count(sonar5 < 1), better: lower}\n")
    trace = tmp_path / "t.csv"
    Run(compile_file(path), load_backend("pymunk"), trace_path=trace).run()
    assert "metric_better" not in read_trace(trace).header  # the header a file without better: always had


def test_the_shipped_labs_declare_what_their_defaults_get_wrong() -> None:
    """The crane declares nothing: its golden is recorded again byte for byte (tests/hostile/test_file_access.py)."""
    better = {}
    for lab in ("wall_follow", "road_follow", "crane"):
        program = compile_file(BEHAVIOURS / f"{lab}.yaml")
        better.update({f"{lab}.{m}": b.value if b else None for m, b in zip(program.metric_names,
                                                                              program.metric_better)})
    assert better == {
        "wall_follow.near_misses": "lower", "wall_follow.overshoot": "lower", "wall_follow.following": "higher",
        "wall_follow.smoothness": "lower", "wall_follow.closest": "higher",
        "road_follow.lateral_rms": "lower", "road_follow.lateral_max": "lower", "road_follow.off_road": "lower",
        "road_follow.laps": "higher", "road_follow.mean_speed": "higher",
        "crane.max_swing": "lower", "crane.final_swing": "higher", "crane.highest_load": "lower",
        "crane.max_tension": "lower", "crane.final_tension": "higher", "crane.final_slew": "higher",
    }
