"""Hands on the world as trace events: each change's text reads back as the same change."""
from __future__ import annotations

import pytest

from labsim.runtime.hands import BlockAdd, BlockMove, BlockRemove, Place, event_text, parse_event


@pytest.mark.parametrize("hand", [
    Place("pioneer", 1.5, -0.25, 3.0), Place("r", 0.1 + 0.2, 1e-300, -3.141592653589793),
    BlockMove(0, 4.5, 6.5), BlockMove(12, 0.30000000000000004, -2.0),
    BlockAdd(1, 2.0, 3.0, 0.5, 0.5), BlockRemove(3),
])
def test_an_event_reads_back_as_the_same_change(hand: object) -> None:
    assert parse_event(event_text(hand)) == hand  # type: ignore[arg-type]


@pytest.mark.parametrize("text", ["arm=5", "log: block move 0 1 2", "bumps", ""])
def test_other_events_are_not_changes(text: str) -> None:
    assert parse_event(text) is None


@pytest.mark.parametrize("text", ["place pioneer 1 2", "place pioneer 1 2 nan", "block move 0 1", "block add 1 1 2 3",
                                  "block remove -1", "block turn 0 1 2", "block move 0 inf 2", "block remove 9999999"])
def test_malformed_changes_are_refused(text: str) -> None:
    with pytest.raises(ValueError):
        parse_event(text)


def test_a_camera_sees_a_block_added_and_removed_and_a_block_on_a_robot_is_refused() -> None:
    """Through the pymunk backend, with no step between: what the robot reads changes at once."""
    import math

    import numpy as np
    from helpers import ROOT

    from labsim.backends import load_backend
    from labsim.runtime.run import compile_behaviour

    behaviour = compile_behaviour(ROOT / "behaviours" / "road_follow.yaml")
    backend = load_backend("pymunk")
    run = behaviour.bind(backend)
    run.tick()
    p = behaviour.program
    camera = next(c.name for c in run.robots[0].model.cameras if c.name in p.channels)  # type: ignore[union-attr]
    k = p.channels.index(camera)
    x, y, h = backend.pose(0)
    ahead = (x + 5.0 * math.cos(h), y + 5.0 * math.sin(h))  # the mast camera looks 30 degrees down
    before = np.array(backend.sense()[0][k])
    block = len(p.world.blocks)
    corners = tuple((ahead[0] + dx, ahead[1] + dy) for dx, dy in ((-0.3, -0.3), (0.3, -0.3), (0.3, 0.3), (-0.3, 0.3)))
    assert backend.set_block(block, corners) is None
    seen = np.array(backend.sense()[0][k])
    assert (seen != before).any()
    assert backend.set_block(block, None) is None
    assert (np.array(backend.sense()[0][k]) == before).all()
    on_robot = tuple((x + dx, y + dy) for dx, dy in ((-0.1, -0.1), (0.1, -0.1), (0.1, 0.1), (-0.1, 0.1)))
    assert backend.set_block(block + 1, on_robot) == "it would overlap a robot there"
    run.close()
