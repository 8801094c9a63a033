"""Range analysis (dsl/analysis/ranges.py): interval arithmetic that never claims what nan or inf breaks,
and the range warnings' silence where a comparison can go either way."""
from __future__ import annotations

import math
from pathlib import Path

import pytest

from labsim.dsl.analysis.ranges import TOP, Range, _holds, add, div, mod, mul, neg
from labsim.dsl.compile import compile_file

INF = math.inf
SONAR = Range(0.0, INF)
UNIT = Range(-1.0, 1.0)

HEAD = """labsim: 1.2
world: walls_lab4
stop: time >= 1
robots:
  pioneer: {model: pioneer_p3dx, at: [0, 0, 0]}
"""


def range_warnings(tmp_path: Path, body: str, head: str = HEAD, overrides: dict[str, str] | None = None
                   ) -> set[tuple[int, int, str]]:
    """The range and trig warnings of HEAD + body (the others are not what these tests are about)."""
    path = tmp_path / "b.yaml"
    path.write_text(head + body)
    return {(d.line, d.col, d.message) for d in compile_file(path, overrides).warnings
            if "holds:" in d.message or "takes radians" in d.message}


# -- arithmetic ----------------------------------------------------------------------------------
def test_arithmetic_on_bounded_ranges() -> None:
    assert (add(UNIT, Range(2.0, 3.0)).lo, add(UNIT, Range(2.0, 3.0)).hi) == (1.0, 4.0)
    assert (mul(UNIT, Range(-3.0, 2.0)).lo, mul(UNIT, Range(-3.0, 2.0)).hi) == (-3.0, 3.0)
    assert (div(Range(1.0, 2.0), Range(4.0, 8.0)).lo, div(Range(1.0, 2.0), Range(4.0, 8.0)).hi) == (0.125, 0.5)
    assert (neg(SONAR).lo, neg(SONAR).hi) == (-INF, 0.0)
    assert (mod(Range(-50.0, 50.0), Range(2 * math.pi, 2 * math.pi)).hi) == 2 * math.pi


@pytest.mark.parametrize("result", [
    add(SONAR, neg(SONAR)),  # inf - inf
    mul(SONAR, UNIT),  # inf * 0, 0 inside the other range
    div(UNIT, UNIT),  # x / 0
    div(SONAR, SONAR),  # inf / inf
    mod(UNIT, Range(0.0, 0.0)),  # x % 0
], ids=["inf-inf", "inf*0", "x/0", "inf/inf", "x%0"])
def test_what_can_be_nan_is_everything(result: Range) -> None:
    assert result == TOP


def test_nan_never_always_holds_but_still_never_does() -> None:
    maybe_nan = Range(0.0, 1.0, nan=True)
    assert _holds(maybe_nan, "<", 2.0) is None  # nan < 2 is false: not always
    assert _holds(maybe_nan, ">", 2.0) is False  # nan > 2 is false too: still never
    assert _holds(maybe_nan, "!=", 2.0) is True  # nan != 2 holds
    assert _holds(Range(0.0, 1.0), "<=", 1.0) is True
    assert _holds(Range(0.0, 1.0), "<", 1.0) is None
    assert _holds(Range(64.0, 64.0), "==", 64.0) is True


# -- warnings that stay silent -------------------------------------------------------------------
@pytest.mark.parametrize("condition", [
    "sin(pi / 2) > x", "sin(2) > x", "cos(-6) > x", "tan(rad(45)) > x",  # radians
    "sonar5 == inf", "sonar5 < inf", "sonar5 != inf", "sonar5 > 0.5",  # the sonar idioms
    "forward_speed > 1.2",  # at the wheels' limit: a bump may pass it
    "sqrt(x) >= 0",  # nan when x < 0, and nan >= 0 is false
    "heading - sonar5 > 0", "sonar5 * heading < 1", "sonar5 / heading > 0",  # inf * 0 and the like
    "abs(heading) > rad(90)", "x > 7", "time >= 2",
    "-pi <= heading <= pi", "sonar5 >= 0", "time >= 0",  # guards at the range's own ends: harmless
    "gauss(0, 1) > 100", "prev(heading, 100) > 50",
])
def test_a_comparison_the_range_does_not_decide_gives_no_warning(tmp_path: Path, condition: str) -> None:
    assert range_warnings(tmp_path, f"rules:\n  - if {condition} then move(1)\n  - else stop()\n") == set()


def test_a_parameter_a_robot_sets_for_itself_is_not_one_value(tmp_path: Path) -> None:
    head = HEAD.replace("at: [0, 0, 0]}", "at: [0, 0, 0], params: {limit: 1}}")
    body = "params:\n  limit: 100\nrules:\n  - if heading > limit then move(1)\n  - else stop()\n"
    assert range_warnings(tmp_path, body, head) == set()


def test_a_world_without_walls_all_round_does_not_bound_the_pose(tmp_path: Path) -> None:
    (tmp_path / "open.yaml").write_text("labsim-world: 1\nname: open\ndescription: a floor\n"
                                        "bounds: [-5, -5, 5, 5]\nwalls:\n  - {from: [-5, -5], to: [5, -5]}\n")
    head = HEAD.replace("walls_lab4", "open.yaml")
    assert range_warnings(tmp_path, "rules:\n  - if x > 8 then move(1)\n  - else stop()\n", head) == set()


# -- warnings that speak ---------------------------------------------------------------------------
def test_a_chain_gives_its_pair_and_no_hint_when_radians_would_not_help(tmp_path: Path) -> None:
    body = "rules:\n  - if 0 < heading < 10 then move(1)\n  - if heading > 270 then move(2)\n  - else stop()\n"
    assert range_warnings(tmp_path, body) == {
        (7, 12, "'heading < 10' always holds: heading is in radians, from -pi to pi (-180 to 180 degrees); "
                "did you mean heading < rad(10)?"),
        (8, 8, "'heading > 270' never holds: heading is in radians, from -pi to pi (-180 to 180 degrees)")}


def test_a_value_far_down_a_chain_of_signals_is_bounded_without_recursion(tmp_path: Path) -> None:
    lets = "".join(f"  a{i}: a{i - 1} * 0.5 + a{i - 1} * 0.5 + 1\n" for i in range(1, 400))
    body = f"let:\n  a0: heading\n{lets}rules:\n  - if a399 > 1000 then move(1)\n  - else stop()\n"
    (found,) = range_warnings(tmp_path, body)
    assert found[2].startswith("'a399 > 1000' never holds: 'a399' is from 395.9 to 402.1, since heading is in radians")


def test_an_override_can_silence_the_trig_warning(tmp_path: Path) -> None:
    body = "params:\n  turn: 90\nrules:\n  - if sin(turn) > x then move(1)\n  - else stop()\n"
    assert len(range_warnings(tmp_path, body)) == 1
    assert range_warnings(tmp_path, body, overrides={"turn": "1.5"}) == set()


def test_a_crop_bounds_the_size_and_makes_the_mean_maybe_nan(tmp_path: Path) -> None:
    head = HEAD.replace("at: [0, 0, 0]}", "at: [0, 0, 0], camera: {resolution: [64, 48], fov_deg: 40, "
                                          "height_m: 3, pitch_deg: 30}}")
    body = ("let:\n  part: crop(camera, 0, 0, 10, 10)\nrules:\n  - if height(part) > 100 then move(1)\n"
            "  - if mean(part) <= 255 then move(2)\n  - if centroid(part).x >= 0 then move(3)\n  - else stop()\n")
    assert range_warnings(tmp_path, body, head) == {
        (9, 8, "'height(part) > 100' never holds: 'height(part)' is from 0 to 48, since the camera's image "
               "is 64 x 48 pixels, or a crop of it")}
