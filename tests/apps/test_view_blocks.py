"""Blocks moved, added and removed in a live view: through the backend, into the trace, replayed.

The session is driven with messages as the page sends them (no browser: tests/browser has
the drag itself); the replay is ``labsim run --replay`` of the trace the session wrote.
"""
from __future__ import annotations

from pathlib import Path

import pytest
from helpers import ROOT

from labsim.runtime.cli.main import main
from labsim.runtime.trace import read_trace
from labsim.runtime.view.live import LiveSession
from labsim.runtime.view.session import BadMessage, ChangeRefused

WALL = ROOT / "behaviours" / "wall_follow.yaml"


def live(path: Path, **kw: object) -> LiveSession:
    s = LiveSession(path, {}, warn=lambda m: None, clock=lambda: 0.0, **kw)  # type: ignore[arg-type]
    assert s.load(), s.problems
    return s


@pytest.mark.slow  # seconds: a live session, its trace and a replay of it; handed out first
def test_blocks_changed_by_hand_are_in_the_trace_and_replay_bit_for_bit(tmp_path: Path) -> None:
    live_trace, replayed = tmp_path / "live.csv", tmp_path / "replayed.csv"
    s = live(WALL, trace=live_trace)
    s.advance(30)
    assert "blocks" not in s.frame()  # nothing changed: the scene's blocks are the blocks
    s.handle({"type": "block", "op": "move", "block": 0, "x": 4.0, "y": 6.0})
    assert s.frame()["blocks"] == [[0, [[3.0, 5.0], [5.0, 5.0], [5.0, 7.0], [3.0, 7.0]]]]
    s.advance(30)
    pose = s.frame()["robots"][0]["pose"]
    with pytest.raises(ChangeRefused, match=r"block 0 was not moved to .*overlap a robot"):
        s.handle({"type": "block", "op": "move", "block": 0, "x": pose[0], "y": pose[1]})
    with pytest.raises(ChangeRefused, match=r"not added at .*overlap a wall"):
        s.handle({"type": "block", "op": "add", "x": 3.0, "y": -5.0})  # the inner wall at x = 3
    s.handle({"type": "block", "op": "add", "x": -6.0, "y": 6.0, "width": 0.6, "depth": 0.4})
    s.advance(30)
    s.handle({"type": "block", "op": "remove", "block": 0})
    assert [k for k, _ in s.frame()["blocks"]] == [1]
    with pytest.raises(ChangeRefused, match="outside the world"):
        s.handle({"type": "block", "op": "move", "block": 1, "x": 9.0, "y": 0.0})
    for bad in ({"op": "move", "block": 0, "x": 0, "y": 0}, {"op": "turn", "block": 1},
                {"op": "add", "x": "a", "y": 0}, {"op": "remove", "block": True}):
        with pytest.raises(BadMessage):
            s.handle({"type": "block", **bad})
    s.advance(200)
    s.close()
    assert main(["run", str(WALL), "--replay", str(live_trace), "--trace", str(replayed), "-q"]) == 0
    a, b = read_trace(live_trace), read_trace(replayed)
    assert b.rows[:len(a.rows)] == a.rows
    events = [e for cell in a.column("events") for e in cell.split(";") if e.startswith("block")]
    assert events == ["block move 0 4.0 6.0", "block add 1 -6.0 6.0 0.6 0.4", "block remove 0"]


def test_a_moved_block_changes_what_the_sonars_see(tmp_path: Path) -> None:
    """The same run with and without the move: the rows part after it, so the move is simulated."""
    traces = [tmp_path / "plain.csv", tmp_path / "moved.csv"]
    for trace in traces:
        s = live(WALL, trace=trace)
        s.advance(5)
        pose = s.frame()["robots"][0]["pose"]
        if trace.name == "moved.csv":  # a block right ahead of the robot
            s.handle({"type": "block", "op": "add", "x": pose[0] + 0.9, "y": pose[1] + 0.9, "width": 0.3, "depth": 0.3})
        s.advance(20)
        s.close()
    plain, moved = (read_trace(t) for t in traces)
    assert plain.rows[:5] == moved.rows[:5] and plain.rows[5:] != moved.rows[5:]


def test_a_replay_that_cannot_change_a_block_says_why(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    trace = tmp_path / "live.csv"
    s = live(WALL, trace=trace)
    s.advance(3)
    s.handle({"type": "block", "op": "move", "block": 0, "x": 4.0, "y": 6.0})
    s.advance(3)
    s.close()
    text = trace.read_text().replace("block move 0 4.0 6.0", "block move 7 4.0 6.0")
    trace.write_text(text)
    assert main(["run", str(WALL), "--replay", str(trace), "-q"]) == 2
    assert "'block move 7 4.0 6.0' cannot be done: there is no block 7" in capsys.readouterr().err
    trace.write_text(text.replace("block move 7 4.0 6.0", "block move 7 x 6.0"))
    assert main(["run", str(WALL), "--replay", str(trace), "-q"]) == 2
    assert "event 'block move 7 x 6.0': its numbers are not numbers" in capsys.readouterr().err
