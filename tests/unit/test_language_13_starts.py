"""Format 1.3's per-robot starts: a group's ``at:`` as a list of poses, one per member, each checked as a
single ``at:`` is."""
from __future__ import annotations

import math
from pathlib import Path

import pytest

from labsim.backends.scene.world import PLACEMENT_CLEARANCE_M
from labsim.dsl.compile import compile_file
from labsim.foundation.diagnostics import LabsimError

HEAD = "labsim: 1.3\nworld: walls_lab4\nstop: tick >= 5\nrobots:\n"
RULES = "rules:\n  - always move(1)\n"


def diagnostics(path: Path) -> list[tuple[int, int, str, tuple[str, ...]]]:
    with pytest.raises(LabsimError) as e:
        compile_file(path)
    return [(d.line, d.col, d.message, d.notes) for d in e.value.diagnostics]


def test_each_member_starts_at_its_own_pose(write) -> None:
    path = write(HEAD + "  p: {model: pioneer_p3dx, count: 3, at: [[-3, -3, 0], [0, -3, 90], [3, -3]]}\n"
                 "  q: {model: pioneer_p3dx, at: [[2, 2, -90]]}\n" + RULES)
    starts = compile_file(path).starts
    assert [(s.name, s.pose.x_m, s.pose.y_m, s.pose.heading_rad) for s in starts] == [
        ("p[0]", -3, -3, 0.0), ("p[1]", 0, -3, math.pi / 2), ("p[2]", 3, -3, 0.0), ("q", 2, 2, -math.pi / 2)]


def test_the_list_is_checked_against_count(write) -> None:
    path = write(HEAD + "  p: {model: pioneer_p3dx, count: 2, at: [[-3, -3, 0], [0, -3, 90], [3, -3, 180]]}\n"
                 + RULES)
    assert diagnostics(path) == [(5, 42, "robot 'p' has 2 members, so 'at' needs 2 poses, one each, not 3",
                                  ("give one [x, y, heading_deg] per robot, or set 'count: 3'",))]


def test_a_group_of_one_takes_one_pose_in_a_list(write) -> None:
    path = write(HEAD + "  p: {model: pioneer_p3dx, at: [[-3, -3, 0], [0, -3, 90]]}\n" + RULES)
    assert diagnostics(path)[0][2] == "robot 'p' has 1 member, so 'at' needs 1 pose, one each, not 2"


@pytest.mark.parametrize(("at", "col", "message"), [
    ("[[-3, -3, 0], spawn]", 56, "each start pose of a list is [x, y] or [x, y, heading_deg]"),
    ("[[-3, -3, 0], [1, 30]]", 56, "(1, 30) is outside world 'walls_lab4' (-7.5..7.5 x -7.5..7.5)"),
    ("[[-3, -3, 0], [1, x]]", 60, "a coordinate must be a number, not 'x'"),
    ("[[-3, -3, 0], [1]]", 56, "each start pose of a list is [x, y] or [x, y, heading_deg]"),
    ("[[-3, -3, 0], [1, 2, 3, 4]]", 56, "each start pose of a list is [x, y] or [x, y, heading_deg]"),
    ("[[-3, -3, 0], [[1, 1]]]", 56, "each start pose of a list is [x, y] or [x, y, heading_deg]"),
    ("[]", 42, "robot 'p' has 2 members, so 'at' needs 2 poses, one each, not 0"),
])
def test_each_pose_is_checked_at_its_place(write, at: str, col: int, message: str) -> None:
    path = write(HEAD + f"  p: {{model: pioneer_p3dx, count: 2, at: {at}}}\n" + RULES)
    assert [(line, c, m) for line, c, m, _ in diagnostics(path)] == [(5, col, message)]


def test_members_on_top_of_each_other_are_reported_at_the_later_pose(write) -> None:
    path = write(HEAD + "  p: {model: pioneer_p3dx, count: 3, at: [[-3, -3, 0], [0, -3, 90], [0.1, -3, 180]]}\n"
                 + RULES)
    assert [(line, col) for line, col, _, _ in diagnostics(path)] == [(5, 69)]


def test_a_pose_in_a_wall_warns_at_that_pose(write) -> None:
    path = write(HEAD + "  p: {model: pioneer_p3dx, count: 2, at: [[-3, -3, 0], [-7.4, 3]]}\n" + RULES)
    warnings = [(d.line, d.col, d.message) for d in compile_file(path).warnings]
    assert warnings == [(5, 56, "the start pose (-7.4, 3) overlaps a wall: the nearest is 0.05 m from its centre, "
                                "and the robot reaches 0.21 m")]


def test_a_list_of_poses_is_format_1_3(write) -> None:
    path = write(HEAD.replace("1.3", "1.2") + "  p: {model: pioneer_p3dx, count: 2, at: [[-3, -3, 0], [0, -3]]}\n"
                 + RULES)
    assert [(line, col, m) for line, col, m, _ in diagnostics(path)] == [
        (5, 42, "a list of start poses, one per robot, is format 1.3: start the file with 'labsim: 1.3'")]


@pytest.mark.parametrize("version", ["1.2", "1.3"])
def test_robots_placed_at_random_keep_clear_of_every_given_pose_declared_before_or_after(write, version: str) -> None:
    at = "[[0, 0], [1, 1], [-1, -1], [2, -2]]" if version == "1.3" else "[0, 0]"
    path = write(HEAD.replace("1.3", version).replace("tick >= 5", "tick >= 1")
                 + f"  b: {{model: pioneer_p3dx, count: 40, at: random}}\n"
                 f"  a: {{model: pioneer_p3dx, count: {4 if version == '1.3' else 1}, at: {at}}}\n"
                 "  s: {model: pioneer_p3dx, count: 2, at: spawn}\nseed: 3\n" + RULES)
    starts = compile_file(path).starts
    given = [s.pose for s in starts if not s.name.startswith("b")]
    drawn = [s.pose for s in starts if s.name.startswith("b")]
    assert len(drawn) == 40 and [s.name for s in starts][:2] == ["b[0]", "b[1]"]  # named in the file's order
    assert min(math.hypot(p.x_m - q.x_m, p.y_m - q.y_m) for p in drawn for q in given) >= 2 * PLACEMENT_CLEARANCE_M
    # the same draws, the later given poses only turning away the ones too near them
    earlier = compile_file(write(HEAD.replace("1.3", version) + "  b: {model: pioneer_p3dx, count: 3, at: random}\n"
                                 "seed: 3\n" + RULES)).starts
    assert [s.pose for s in earlier] == drawn[:3]


def test_the_hints_for_stacked_robots_and_too_few_spawn_poses_name_a_pose_for_each_robot(write) -> None:
    path = write(HEAD + "  p: {model: pioneer_p3dx, count: 3, at: [1, 2, 0]}\n" + RULES)
    assert diagnostics(path) == [(5, 42, "the 3 robots of 'p' would all start at (1, 2), on top of each other",
                                  ("give each robot its own pose, as in 'at: [[1, 2], [2, 2], ...]', or the group "
                                   "'at: random' or 'at: spawn'",))]
    path = write(HEAD + "  p: {model: pioneer_p3dx, count: 9, at: spawn}\n" + RULES)
    assert diagnostics(path) == [(5, 42, "world 'walls_lab4' has 5 spawn poses, too few for 9 robots placed "
                                         "'at: spawn'",
                                  ("use 'at: random', fewer robots, or a pose for each robot: 'at: [[x, y, "
                                   "heading_deg], ...]'",))]
    path = write(HEAD + "  p: {model: pioneer_p3dx, count: 2, at: []}\n" + RULES)
    assert diagnostics(path)[0][3] == ("give one [x, y, heading_deg] per robot, as in at: [[-3, -3, 0], [0, -3, 90]]",)
