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
