"""The live view's tick hook in C (runtime/view/_tap.c) against the Python it stands in for.

The recorder keeps, every tick, the robot's path (``PathThinner``) and its chart values; where
the install built the C extension, its ``Path`` and ``Tap`` do that work. Here both are held to
the Python: a path thinned by each keeps the same points, and a page fed by each hook (the C
one, the generated Python one and the general one, which every tick takes while a breakpoint
is set) gets the same frames, on every lab; a value that is no number is a gap either way.
Without the extension the C half is skipped with how to build it (failed under CI).
"""
from __future__ import annotations

import gc
import json
import math
import os
import random
import weakref
from pathlib import Path

import numpy as np
import pytest
from helpers import ROOT, examples

from labsim.runtime.view import peaks, record
from labsim.runtime.view.live import LiveSession
from labsim.runtime.view.record import MAX_PATH_POINTS, PATH_TOLERANCE_M, PathThinner

LABS = [ROOT / "behaviours" / f"{name}.yaml" for name in ("wall_follow", "road_follow", "crane", "line_follow")]
HOW = ("the C extension runtime/view/_tap.c was not built: `pip install .` builds it where a C compiler is "
       "(an editable checkout: `pip install -e .`)")


class FakeClock:
    def __call__(self) -> float:
        return 0.0


def tap_built() -> None:
    """Skip a test of the C hook where it was not built; under CI, fail it."""
    if peaks._tap is None:
        if os.environ.get("CI", "").lower() == "true":
            pytest.fail(HOW)
        pytest.skip(HOW)


def _same_points(a: list, b: list) -> bool:
    """Points equal, a gap's (nan, nan) equal to another's."""
    return len(a) == len(b) and all(
        (math.isnan(p[0]) and math.isnan(q[0])) or p == q for p, q in zip(a, b))


def _walk(rng: random.Random, steps: int) -> list[tuple[float, float]]:
    """A robot's positions: runs straight, arcs, turns on the spot, reverses, stands, jitters,
    now and then a nan or an inf (a reading that is no position)."""
    x = y = 0.0
    heading, out = 0.0, []
    for _ in range(steps):
        kind = rng.random()
        if kind < 0.01:
            out.append((rng.choice([math.nan, math.inf, -math.inf]), y))
            continue
        speed = rng.choice([0.0, 0.001, 0.004, 0.01, -0.006])
        heading += rng.choice([0.0, 0.0, 0.02, -0.05, 0.3])
        x += speed * math.cos(heading) + rng.gauss(0, 0.0005)
        y += speed * math.sin(heading) + rng.gauss(0, 0.0005)
        out.append((x, y))
    return out


@pytest.mark.parametrize("seed", range(12))
def test_the_c_path_keeps_the_points_the_python_one_keeps(seed: int) -> None:
    tap_built()
    rng = random.Random(seed)
    tol = rng.choice([PATH_TOLERANCE_M, 0.001, 0.05])
    most = rng.choice([MAX_PATH_POINTS, 7])
    c, py = peaks._tap.Path(tol, most), PathThinner(tol)
    if most != MAX_PATH_POINTS:
        record.MAX_PATH_POINTS, kept_most = most, MAX_PATH_POINTS  # the Python one reads the module's
    try:
        for k, (x, y) in enumerate(_walk(rng, 3000)):
            if rng.random() < 0.003:  # put elsewhere by hand
                c.jump(x + 1.0, y), py.jump(x + 1.0, y)
            else:
                c.add(x, y), py.add(x, y)
            assert c.pending() == py.pending(), k
            if rng.random() < 0.02:  # a frame takes what was kept
                assert _same_points(c.take(), py.take()), k
        assert _same_points(c.points, py.points)
        assert c.tol == py.tol
    finally:
        if most != MAX_PATH_POINTS:
            record.MAX_PATH_POINTS = kept_most


def test_a_c_path_refuses_what_is_no_point() -> None:
    tap_built()
    p = peaks._tap.Path()
    with pytest.raises(TypeError):
        p.add("1", 2.0)
    with pytest.raises(TypeError):
        p.add(1.0)
    with pytest.raises(TypeError):
        p.points = None
    p.add(1, 2)  # ints are numbers
    assert p.take() == [(1.0, 2.0)] and p.take() == []


def _sessions(path: Path, monkeypatch: pytest.MonkeyPatch) -> list[LiveSession]:
    """Three pages of one lab: the C hook, the generated Python one, and the general one (a
    breakpoint that never holds sends every tick its way)."""
    out = []
    for kernel, breaks in (("c", []), ("python", []), ("python", ["time:100000"])):
        monkeypatch.setattr(peaks, "KERNEL", kernel)
        s = LiveSession(path, {"front": "0.05"} if path.stem == "wall_follow" else {}, warn=lambda m: None,
                        clock=FakeClock(), breaks=breaks)
        assert s.load(), s.problems
        out.append(s)
    return out


@pytest.mark.parametrize("name", [p.stem for p in LABS] + ["lidar_sectors", "formation_of_three"])
def test_each_tick_hook_gives_the_page_the_same_frames(name: str, tmp_path: Path,
                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    # the wall lab at a 5 cm threshold bumps into walls: collisions begun and ended; the road lab
    # is five robots; the crane's timeline moves its sliders, and its chart columns are parts of
    # joints' readings, which go the general way whichever hook is built; docs/language.md's
    # lidar example charts its 360 beams, and the formation's three robots read each other
    tap_built()
    path = ROOT / "behaviours" / f"{name}.yaml"
    if not path.exists():
        path = tmp_path / f"{name}.yaml"
        path.write_text(examples()[name])
    sessions = _sessions(path, monkeypatch)
    c, generated, general = sessions
    fast = name != "crane"
    assert isinstance(c.recorder.after_act, peaks._tap.Tap) is fast
    assert ("after_act" in vars(generated.recorder)) is fast
    assert not isinstance(generated.recorder.after_act, peaks._tap.Tap)
    assert isinstance(c.recorder.paths[0], peaks._tap.Path) and isinstance(generated.recorder.paths[0], PathThinner)
    for stretch in (1, 7, 333, 1009, 2, 1009, 4000):
        ran = {s.advance(stretch) for s in sessions}
        assert len(ran) == 1
        frames = [s.frame() for s in sessions]
        for f in frames[1:]:
            assert f["robots"] == frames[0]["robots"], stretch
            assert f["events"] == frames[0]["events"], stretch
    if name == "wall_follow":
        assert c.recorder.collisions[0] > 0
    for s in sessions:
        s.close()


def test_a_value_that_is_no_number_is_kept_as_a_gap_by_either_hook(monkeypatch: pytest.MonkeyPatch) -> None:
    # a backend's reading that no double holds (None, a text, an int beyond a double's range)
    # among the chart's columns: packed as nan, the C hook as the generated one
    tap_built()
    c, generated, _ = _sessions(LABS[0], monkeypatch)
    kept = []
    for s in (c, generated):
        s.advance(20)
        s.recorder.take_samples(0)
        robot, rule, values = s.run.robots[0], s.recorder.last_rule[0], list(s.recorder.last[0])
        for odd in (None, "far", 10 ** 400, -10 ** 400, True, 3):
            values[0] = odd
            s.recorder.after_act(robot, rule, values)
        kept.append(s.recorder.samples[0].numbers())
    assert kept[0] is not None and kept[1] is not None
    assert kept[0].shape == kept[1].shape == (6, c.recorder.width)
    assert kept[0].tobytes() == kept[1].tobytes()
    first = [kept[0][k][0] for k in range(6)]
    assert all(math.isnan(v) for v in first[:2]) and first[2:] == [math.inf, -math.inf, 1.0, 3.0]


def test_the_c_hook_is_let_go_with_its_page() -> None:
    tap_built()
    s = LiveSession(LABS[0], {}, warn=lambda m: None, clock=FakeClock())
    assert s.load() and isinstance(s.recorder.after_act, peaks._tap.Tap)
    s.advance(50)
    gone = weakref.ref(s.recorder)
    s.load()  # Restart: a new recorder, the old one with its hook unreachable (a cycle through the hook)
    s.close()
    del s
    gc.collect()
    assert gone() is None


@pytest.mark.parametrize("seed", range(40))
def test_the_c_envelope_gives_the_rows_numpy_gives(seed: int) -> None:
    # packed ticks with nan, inf and -inf, flat stretches, steps, signed zeros, columns with no
    # number; any count of ticks and of rows asked for
    tap_built()
    rng = np.random.default_rng(seed)
    n, width = int(rng.integers(3, 400)), int(rng.integers(1, 9))
    kinds = [rng.random((n, width)), np.round(rng.random((n, width)) * 3),
             rng.choice([0.0, -0.0, 1.5, -2.0, np.nan, np.inf, -np.inf], size=(n, width))]
    data = kinds[seed % 3]
    columns = rng.integers(-1, width, size=int(rng.integers(0, 7)))
    at_most = int(rng.integers(2, n + 2))  # fewer rows than ticks, or all of them
    times = np.round(np.arange(5, 5 + n, dtype=float) * 0.05, 9)
    m = np.concatenate((data, np.full((n, 1), np.nan)), axis=1)[:, np.where(columns >= 0, columns, width)].T
    want = peaks.pairs(times, np.ascontiguousarray(m), at_most)
    got = peaks.packed_pairs(data.tobytes(), width, columns.astype(np.intp), times, at_most)
    assert json.dumps(got) == json.dumps(want)


def test_the_c_envelope_refuses_what_disagrees() -> None:
    tap_built()
    data = np.zeros((4, 2)).tobytes()
    starts = np.array([0, 2], dtype=np.intp)
    for width, columns, first, rows in ((2, [2], starts, 4), (2, [0], starts, 5), (2, [0], starts[::-1].copy(), 4),
                                        (3, [0], starts, 4), (0, [-1], starts, 10 ** 15)):
        with pytest.raises(ValueError):
            peaks._tap.envelope(data, width, np.array(columns, dtype=np.intp), first, rows)
    with pytest.raises(ValueError, match="aligned"):
        peaks._tap.envelope(memoryview(b"x" + data)[1:], 2, np.array([0], dtype=np.intp), starts, 4)


def test_a_tap_refuses_what_it_cannot_use() -> None:
    tap_built()
    tap = peaks._tap.Tap.__new__(peaks._tap.Tap)
    with pytest.raises(TypeError, match="made with Tap"):
        tap(None, 0, [])  # made but not set up: no crash
    lists = [[] for _ in range(7)]

    def made(state: int = 2, x: int = -1, y: int = -1, hit: int = -1, columns: object = ()) -> object:
        return peaks._tap.Tap(print, print, *lists[:6], lists[6], None, [], [], state, x, y, hit, 800, columns, ())
    for bad in ({"state": -1}, {"x": 3}, {"x": -2, "y": -2}, {"hit": -5}, {"columns": [1, -1]}, {"columns": ["a"]}):
        with pytest.raises((ValueError, TypeError)):
            made(**bad)  # type: ignore[arg-type]
    tap = made()
    with pytest.raises(TypeError, match="made once"):
        tap.__init__(print, print, *lists[:6], lists[6], None, [], [], 2, -1, -1, -1, 800, (), ())
    path = peaks._tap.Path.__new__(peaks._tap.Path)  # not set up: still a path, not a crash
    path.add(1.0, 2.0)
    path.jump(3.0, 4.0)
    kept = path.take()
    assert path.pending() is None and kept[0] == (1.0, 2.0) and math.isnan(kept[1][0]) and kept[2] == (3.0, 4.0)
    assert path.points == []


def test_huge_finite_values_are_charted_as_they_are() -> None:
    # 4 decimals by multiplying by 10^4 overflowed beyond 1.8e304: finite values sent as "inf"
    m = np.array([[-1e308, 1e308, 2.5e306, -0.00004, 1.23456789]])
    rows, _ = peaks.pairs(np.arange(5.0), m, 10)
    assert [r[1] for r in rows] == [-1e308, 1e308, 2.5e306, 0.0, 1.2346]
    assert str(rows[3][1]) == "0.0"  # no -0.0


def test_an_inf_tick_in_a_group_leaves_its_finite_range_drawn() -> None:
    # a ramp down with inf every fifth tick (a gap on the page): each group's pair is the ramp's
    # least and greatest there, not the ramp's least and a gap; a group of infs alone is a gap
    ramp = np.array([[math.inf if k % 5 == 0 else -float(k) for k in range(1, 121)] + [math.inf] * 20])
    times = np.arange(140.0)
    for rows, bands in (peaks.pairs(times, ramp, 28),
                        peaks.packed_pairs(np.ascontiguousarray(ramp.T).tobytes(), 1, np.array([0], dtype=np.intp),
                                           times, 28)):
        values = [r[1] for r in rows]
        assert values[:2] == [-1.0, -9.0] and values[-2:] == [None, None]
        assert all(v is None or v < 0 for v in values) and bands[0] == "0"  # a line: it only fell
