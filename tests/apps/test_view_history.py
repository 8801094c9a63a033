"""The view's history: what a page that opens late (or a replay's seek) is sent before frames.

A replay that seeks draws what the trace recorded up to there, exactly as playing there draws
it; a live run's history holds what its frames drew, bounded, with every peak kept.
"""
from __future__ import annotations

import itertools
import json
import math
import subprocess
import sys
from pathlib import Path

import pytest
from helpers import ROOT

from labsim.runtime.view.history import MAX_POINTS, MAX_ROWS, History, paired, series_doc
from labsim.runtime.view.live import LiveSession
from labsim.runtime.view.replay import load_replay

WALL = ROOT / "behaviours" / "wall_follow.yaml"


@pytest.fixture(scope="module")
def wall_trace(tmp_path_factory: pytest.TempPathFactory) -> Path:
    trace = tmp_path_factory.mktemp("trace") / "wall.csv"
    subprocess.run([sys.executable, "-m", "labsim", "run", str(WALL), "--set", "minutes=0.5", "--trace", str(trace)],
                   check=True, capture_output=True, cwd=ROOT)
    return trace


def _played(s, to: int) -> tuple[list, list]:  # type: ignore[no-untyped-def]
    """What a page draws from the frames while the replay plays (one row a frame) up to ``to``."""
    path: list = []
    rows: list = []
    s.restart()
    s.history()
    while True:
        f = s.frame()
        r = f["robots"][0]
        path += r.get("path", []) + [r["pose"][:2]]
        rows += r.get("samples", []) + [[f["time"], *r["values"]]]
        if f["tick"] >= to:
            return path, rows
        s.advance(1)


def _seeked(s, to: int) -> tuple[list, list]:  # type: ignore[no-untyped-def]
    s.seek(to)
    h = s.history()["robots"][0]
    f = s.frame()
    r = f["robots"][0]
    return h["path"] + r.get("path", []) + [r["pose"][:2]], h["samples"] + r.get("samples", []) + [
        [f["time"], *r["values"]]]


def test_a_replay_seek_draws_what_playing_there_draws(wall_trace: Path) -> None:
    s = load_replay(wall_trace)
    played = _played(s, 250)
    forward = _seeked(s, 250)
    assert forward == played
    assert len(forward[0]) == 251 and [row[0] for row in forward[1]] == [round(k * 0.05, 9) for k in range(251)]
    _seeked(s, 400)
    assert _seeked(s, 250) == played  # back, then there again: the same
    assert _seeked(s, 100) == _played(s, 100)


def test_a_replay_frame_after_a_fast_stretch_carries_its_rows_and_no_jump(wall_trace: Path) -> None:
    s = load_replay(wall_trace)
    s.history()
    s.frame()
    s.advance(200)  # "as fast as it goes": 200 rows between two frames
    r = s.frame()["robots"][0]
    samples = r["samples"]
    assert len(samples) <= 24 and samples[0][0] == 0.05 and samples[-1][0] == 9.95  # the first and last between
    assert all(p is not None for p in r["path"]) and len(json.dumps(s.frame())) < 4096
    s.seek(500)
    assert s.jumped and s.history()["tick"] == 500 and not s.jumped
    assert "path" not in s.frame()["robots"][0]  # nothing drawn across the skipped rows


def test_a_seek_starts_the_real_time_factor_again(wall_trace: Path) -> None:
    now = [0.0]
    s = load_replay(wall_trace, clock=lambda: now[0])
    s.play()
    for _ in range(10):
        now[0] += 0.05
        s.catch_up()
    assert s.real_time_factor() == pytest.approx(1.0)
    s.seek(500)
    now[0] += 0.05
    s.catch_up()
    assert s.real_time_factor() is None or s.real_time_factor() == pytest.approx(1.0)  # not 500 ticks in 0.05 s


def test_envelopes_keep_every_peak_and_stay_bounded() -> None:
    h = History(1)
    for k in range(0, 20_000, 50):  # a signal that flips sign every tick, 20,000 ticks
        h.add(0, [], [[k * 0.05 + j * 0.05, 1.0 if (k + j) % 2 else -1.0, "inf", None] for j in range(50)])
    rows = h.rows[0]
    assert len(rows) <= MAX_ROWS
    values = [r[1] for r in rows]
    assert values[0::2] == [-1.0] * (len(rows) // 2) and values[1::2] == [1.0] * (len(rows) // 2)
    assert all(r[2] == "inf" and r[3] is None for r in rows)
    times = [r[0] for r in rows]
    assert times == sorted(times) and times[0] == 0.0 and math.isclose(times[-1], 19_999 * 0.05)


def test_a_trace_s_rows_are_paired_as_a_live_frame_s() -> None:
    # a flip, a rise, a fall, a column with a gap: 100 rows as 5 pairs of 20
    rows = [[round(k * 0.1, 9), (-1.0) ** k, float(k), -float(k), None if k % 3 else 1.0] for k in range(100)]
    out, bands = paired(rows, 10)
    assert len(out) == 10 and bands == ["1000"] * 5
    assert out[0] == [0.0, -1.0, 0.0, -0.0, 1.0] and out[1] == [1.9, 1.0, 19.0, -19.0, 1.0]  # the fall: greatest first
    assert out[8][0] == 8.0 and out[9][0] == 9.9
    assert paired(rows[:10], 10) == (rows[:10], None)
    out, bands = paired(rows[:13], 8)  # groups of 3, 3, 3 and 4
    assert [r[0] for r in out] == [0.0, 0.2, 0.3, 0.5, 0.6, 0.8, 0.9, 1.2] and bands == ["1000"] * 4
    doc = series_doc(rows, 10)
    assert doc["samples"] == paired(rows, 10)[0] and doc["bands"] == ["1000"] * 10
    assert doc["spans"][0] == 1.9 and doc["spans"][1] == 0.0


def test_a_long_path_is_thinned_but_keeps_its_jumps() -> None:
    h = History(1)
    h.add(0, [[float(k), 0.0] for k in range(3000)] + [[None, None]] + [[float(k), 1.0] for k in range(3000)], [])
    p = h.paths[0]
    assert len(p) <= MAX_POINTS and p.count(None) == 1 and p[-1] == [2999.0, 1.0]


def test_a_live_history_holds_what_the_frames_drew() -> None:
    s = LiveSession(WALL, {}, warn=lambda m: None)
    assert s.load()
    drawn: list = []
    for _ in range(20):
        s.advance(37)
        r = s.frame()["robots"][0]
        drawn += r["path"] + [r["pose"][:2]]
    h = s.history()
    assert h["type"] == "history" and h["tick"] == 20 * 37 - 1
    assert h["robots"][0]["path"] == drawn
    assert h["robots"][0]["samples"][-1][0] == round((20 * 37 - 1) * 0.05, 9)
    peek = s.frame(take=False)["robots"][0]
    assert peek["path"] == [] and peek["samples"] == [] and s.history() == h  # a page joining takes nothing
    s.close()


def test_a_burst_of_seeks_gets_one_history_for_the_last(wall_trace: Path) -> None:
    import asyncio

    import aiohttp

    from labsim.runtime.view.server import bind_socket, serve

    async def scenario() -> tuple[int, int, int]:
        s = load_replay(wall_trace)
        sock = bind_socket("127.0.0.1", 0)
        url = f"http://127.0.0.1:{sock.getsockname()[1]}"
        task = asyncio.ensure_future(serve(s, sock, url, log=lambda m: None))
        histories = 0
        async with aiohttp.ClientSession() as http:
            for _ in range(200):
                try:
                    ws = await http.ws_connect(url + "/ws")
                    break
                except aiohttp.ClientConnectorError:
                    await asyncio.sleep(0.01)
            for k in range(300):  # a scrubber dragged across the whole trace
                await ws.send_str(json.dumps({"type": "seek", "tick": k}))
            last = None
            while True:
                msg = await ws.receive_json(timeout=10)
                if msg["type"] == "history" and msg["tick"] > 0:
                    histories += 1
                    last = msg
                if msg["type"] == "frame" and msg["tick"] == 299 and last is not None and last["tick"] == 299:
                    break
            await ws.close()
        task.cancel()
        with pytest.raises(asyncio.CancelledError):
            await task
        return histories, len(last["robots"][0]["path"]), last["tick"]

    histories, points, tick = asyncio.run(scenario())
    assert tick == 299 and points == 299 and histories < 30, histories


def test_a_frame_s_pairs_say_which_columns_went_both_ways() -> None:
    from labsim.runtime.view.peaks import Kept, Sampler
    s = Sampler([], [0, 1, 2])

    def kept(n: int) -> Kept:
        k = Kept(0, s.width)
        for t in range(n):
            k.values.extend(((-1.0) ** t, float(t), -float(t)))  # flips, rises, falls
        return k
    rows = s.rows(kept(100), 0.1, 8)
    assert s.paired and s.bands == ["100"] * 4 and len(rows) == 8
    assert rows[0] == [0.0, -1.0, 0.0, 0.0] and rows[1] == [2.4, 1.0, 24.0, -24.0]  # the fall: greatest first
    s.rows(kept(5), 0.1, 8)
    assert not s.paired and s.bands == []


def test_the_history_keeps_bands_spans_events_and_marks_as_it_thins() -> None:
    h = History(1)
    for k in range(MAX_ROWS):  # pairs of four ticks: a flip in column 0, a rise in column 1
        t0, t1 = 0.4 * k, 0.4 * k + 0.3
        h.add(0, [], [[t0, -1.0, t0], [t1, 1.0, t1]], ["10"])
    doc = h.doc(1)["robots"][0]
    rows, spans, bands = doc["samples"], doc["spans"], doc["bands"]
    assert len(rows) <= MAX_ROWS and len(rows) == len(spans) == len(bands)
    assert all(b == "10" for b in bands)
    assert all(r[1] in (-1.0, 1.0) for r in rows) and all(a[2] < b[2] for a, b in itertools.pairwise(rows))
    assert spans[0] == rows[1][0] and spans[1] == rows[0][0]
    h.add(0, [], [[1e4, 0.0, 0.0]], None)  # a tick's own row: no band, no span
    doc = h.doc(1)["robots"][0]
    assert doc["bands"][-1] is None and doc["spans"][-1] is None
    frame = h.frame_events([[k, k * 0.05, "pioneer", f"state a → b {k}"] for k in range(10)])
    assert frame["events"] == [[k, k * 0.05, "pioneer", f"state a → b {k}"] for k in range(6, 10)]
    assert frame["events_more"] == 6 and len(h.doc(1)["events"]) == 10
    h.frame_events([[0, 0.0, "pioneer", "x"]] * 2000)
    assert len(h.doc(1)["events"]) == 1000 and h.doc(1)["events_before"] == 1010
    marks = [[[0, 1.0, 2.0], [0, math.nan, 2.0]]]
    assert h.marked(0, marks, True) == [[0, 1.0, 2.0]] and marks == [[]]
    assert h.doc(1)["robots"][0]["marks"] == [[0, 1.0, 2.0]]
