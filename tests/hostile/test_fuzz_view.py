"""The view's messages, fuzzed: whatever a page (or a hostile page) sends, the session answers
with its own refusal (``BadMessage``, ``ChangeRefused``) or does what was asked, and the run
goes on: a tick, a frame and the scene after every message.

Messages are read as the server reads them (``json.loads`` with labsim's integer rule), and
come from three sources: the message types the page sends with hostile values (huge, infinite,
not-a-number, negative, wrong types, long or control-character text, deep nesting), those types
with keys of their own, and text that is not JSON at all. A live session on a copy of the wall
lab and a replay of its trace are both fed.
"""
from __future__ import annotations

import contextlib
import json
import math
import shutil
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from labsim.foundation.numbers import NumberError
from labsim.runtime.api import run
from labsim.runtime.view.live import ChangeRefused, LiveSession
from labsim.runtime.view.replay import load_replay
from labsim.runtime.view.server import _whole
from labsim.runtime.view.session import BadMessage, Session

ROOT = Path(__file__).resolve().parents[2]
TYPES = ("play", "pause", "step", "speed", "restart", "select", "slider", "params", "timeline", "recheck",
         "break", "place", "apply", "save", "seek", "nonsense")
KEYS = ("value", "name", "on", "text", "robot", "x", "y", "heading", "tick", "params", "kind", "condition", "at")
HOSTILE = st.one_of(
    st.sampled_from([0, -1, 1, 2**63, -(2**70), 1e308, -1e308, math.inf, -math.inf, math.nan, 0.5, True, False,
                     None, "", "max", "sonar5 < 0.5", "state", "rule:follow:1", "time:3", "front", "pioneer",
                     "\x1b[2J", "a" * 5000, "labsim: 1\n", [], {}, [[[[[[]]]]]]]),
    st.integers(), st.floats(), st.text(max_size=60),
    st.dictionaries(st.text(max_size=8), st.one_of(st.integers(), st.floats(), st.text(max_size=8)), max_size=4),
)
SETTINGS = settings(max_examples=400, derandomize=True, database=None, deadline=None,
                    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])


@st.composite
def messages(draw: st.DrawFn) -> str:
    """One message's text, as the page's WebSocket would carry it."""
    kind = draw(st.sampled_from(("typed", "typed", "typed", "raw")))
    if kind == "raw":
        return draw(st.one_of(st.text(max_size=80), st.just("[" * 5000), st.just('{"type": "speed", "value": '
                                                                                 + "9" * 5000 + "}")))
    msg: dict[str, object] = {"type": draw(st.sampled_from(TYPES))}
    for key in draw(st.lists(st.sampled_from(KEYS), max_size=4, unique=True)):
        msg[key] = draw(HOSTILE)
    return json.dumps(msg, allow_nan=True)


def feed(session: Session, text: str) -> None:
    """One message the server's way, then a tick, a frame and the scene: only the session's own
    refusals may come out of it."""
    try:
        msg = json.loads(text, parse_int=_whole)
    except (NumberError, ValueError, RecursionError):
        return  # the server ignores it, as docs/view.md says
    with contextlib.suppress(BadMessage, ChangeRefused):  # the session's own refusals
        session.handle(msg)
    session.advance(1)
    json.dumps(session.frame(), default=str)
    json.dumps(session.scene(), default=str)


@pytest.mark.slow
def test_a_live_sessions_messages_give_refusals_not_exceptions(tmp_path: Path) -> None:
    behaviour = tmp_path / "wall_follow.yaml"
    shutil.copyfile(ROOT / "behaviours" / "wall_follow.yaml", behaviour)
    session = LiveSession(str(behaviour), {"minutes": "1"})
    assert session.load()

    @SETTINGS
    @given(messages())
    def fuzz(text: str) -> None:
        feed(session, text)

    try:
        fuzz()
    finally:
        session.close()


@pytest.mark.slow
def test_a_replays_messages_give_refusals_not_exceptions(tmp_path: Path) -> None:
    trace = tmp_path / "t.csv"
    run(ROOT / "behaviours" / "wall_follow.yaml", params={"minutes": 0.5}, trace=trace)
    session = load_replay(trace)

    @SETTINGS
    @given(messages())
    def fuzz(text: str) -> None:
        feed(session, text)

    fuzz()
