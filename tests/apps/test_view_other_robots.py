"""The live view lists what a behaviour reads of other robots (format 1.3): each value read at a
known place and each channel heard, under "other robots", with the robot's own values, and charts them."""
from __future__ import annotations

import json
from pathlib import Path

from labsim.runtime.view.live import LiveSession

READER = """labsim: 1.3
world: walls_lab4
stop: time >= 60
robots:
  leader: {model: pioneer_p3dx, at: [0, 0, 0], params: {lead: true}}
  follower: {model: pioneer_p3dx, at: [-2, 0, 0]}
params:
  lead: false
let:
  gap: hypot(leader.x - x, leader.y - y)
  leading: leader.state == go
  pinged: heard(ping)
rules:
  wait:
    - when lead then say(ping, tick)
    - if time >= 0.2 then goto go
    - else move(1)
  go:
    - when lead then say(ping, tick)
    - else move(2)
"""


class FakeClock:
    def __call__(self) -> float:
        return 0.0


def test_the_values_read_of_other_robots_are_listed_with_their_values(tmp_path: Path) -> None:
    path = tmp_path / "reader.yaml"
    path.write_text(READER)
    s = LiveSession(path, {}, warn=lambda m: None, clock=FakeClock())  # type: ignore[arg-type]
    assert s.load(), s.problems
    try:
        scene = json.loads(json.dumps(s.scene(), allow_nan=False))
        others = [(c["name"], c["numeric"]) for c in scene["columns"] if c["group"] == "other robots"]
        assert others == [("leader.x", True), ("leader.y", True), ("leader.state", False), ("heard(ping)", True)]
        names = [c["name"] for c in scene["columns"]]
        s.advance(8)
        frame = json.loads(json.dumps(s.frame(), allow_nan=False))
        follower = dict(zip(names, frame["robots"][1]["values"]))
        leader_x = s.run.robots[0].program.slots  # type: ignore[union-attr]
        assert follower["leader.state"] == "go"  # its goto on tick 4 shows in its row of tick 5, read from tick 6
        assert follower["heard(ping)"] == 6.0  # said on tick 6, heard on tick 7 (the one shown)
        assert isinstance(follower["leader.x"], float) and follower["leader.x"] > 0
        assert follower["leader.x"] < leader_x[s.run.program.slot_of["x"]]  # type: ignore[union-attr]  # a tick behind
        assert len(frame["robots"][1]["values"]) == len(names)
    finally:
        s.close()
