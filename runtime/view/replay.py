"""A recorded trace on the same page: ``labsim view TRACE.csv``, with a time scrubber.

``ReplaySession`` reads a trace (``labsim.runtime.trace.read_trace``) and the world it names
(``trace_world``, as ``labsim plot`` finds it), and plays its rows back tick by tick at the
speed the page sets; a ``seek`` message jumps to a tick. A frame holds what the trace recorded: every
robot's pose, state, rule and numeric columns. A trace holds no camera images and, of a
mechanism, its tracked body (the trace's x, y), the slew angle (heading) and whatever bodies
the behaviour recorded as ``<body>_x`` / ``<body>_z`` signals: those are drawn where they were,
with what is fixed to them; the frame names the bodies the trace cannot place, and the page
says so rather than draw them where they were not.
"""
from __future__ import annotations

import bisect
import math
from pathlib import Path
from typing import Any

from labsim.backends.scene.models import MODELS
from labsim.backends.scene.world import World
from labsim.runtime.trace import Trace, TraceFormatError, read_trace, trace_world
from labsim.runtime.view.frames import Json, message, number, robot_doc, world_doc
from labsim.runtime.view.history import MAX_POINTS, MAX_ROWS, paired, series_doc
from labsim.runtime.view.record import PathThinner
from labsim.runtime.view.session import BadMessage, Session

_TEXT = {"tick", "time", "robot", "x", "y", "heading", "collided", "state", "rule", "events"}
# what a page is sent once, in the scene, and in every frame: a trace of 10^6 columns made a
# 35 MB scene. labsim's own traces have a few dozen columns (a thousand signals would be many).
MAX_COLUMNS = 10_000
MAX_ROBOTS = 1000  # the robots budget's default: no run of labsim's has more
FRAME_ROWS = 24  # chart rows a frame carries at most per robot for the rows since the last (least/greatest pairs)


class ReplaySession(Session):
    """See the module docstring."""

    def __init__(self, trace: Trace, world: World | None, note: str = "", **session: Any):
        header = trace.header
        dt = header.get("dt")
        super().__init__(float(dt) if isinstance(dt, (int, float)) and dt > 0 else 0.05, **session)
        self.trace = trace
        self.world = world
        self.note = note
        cols = trace.columns
        self._i = {c: k for k, c in enumerate(cols)}
        self.numeric = [c for c in cols if c not in _TEXT and not c.startswith("label:")]
        recorded = header.get("robots")
        models: dict[str, object] = recorded if isinstance(recorded, dict) else {}
        names = list(dict.fromkeys([*(n for n in models), *trace.column("robot")])) if "robot" in cols else []
        seen = set(trace.column("robot")) if "robot" in cols else set()
        self.robot_names = [n for n in names if n in seen]
        self.models = {n: models.get(n) for n in self.robot_names}
        # rows by tick, in tick order: a trace has one row per robot per tick
        self.rows: list[dict[str, list[str]]] = []
        by_tick: dict[str, dict[str, list[str]]] = {}
        for row in trace.rows:
            t = row[self._i["tick"]] if "tick" in self._i else str(len(by_tick))
            if t not in by_tick:
                by_tick[t] = {}
                self.rows.append(by_tick[t])
            by_tick[t][row[self._i["robot"]] if "robot" in self._i else ""] = row
        self.position = 0
        self.labels = [c for c in cols if c.startswith("label:")]
        self._mechanism_layout()
        self._sent = -1  # the row the last frame showed: the next carries the rows after it
        self._series: list[tuple[list, list]] | None = None  # per robot: every tick's [x, y] and chart row
        self._onsets: list[list[tuple[int, list]]] = []  # per robot: (tick, [x, y]) where each collision began

    @property
    def tick(self) -> int:
        return self.position

    @property
    def finished(self) -> bool:
        return self.position >= len(self.rows) - 1

    def advance(self, n: int) -> int:
        ran = max(0, min(n, len(self.rows) - 1 - self.position))
        self.position += ran
        return ran

    def restart(self) -> None:
        self.seek(0)
        self.playing = False

    def seek(self, tick: int) -> None:
        """Show that row next. The page is then sent the history up to it (``history``), as if
        it had played there: nothing is drawn across the rows skipped, and the real-time factor
        starts again (a jump is not speed)."""
        self.position = max(0, min(tick, len(self.rows) - 1))
        self.pacer.anchor(self.clock(), self.position)
        self._rate.clear()
        self._sent = self.position - 1
        self.jumped = True

    jumped = False  # a seek or a rewind since the last history sent: the server sends one

    def series(self) -> list[tuple[list, list]]:
        """Per robot, every tick's ``[x, y]`` (None where it has no row or no pose) and chart
        row ``[time, value, ...]`` (None where it has no row); read once, when first needed."""
        if self._series is None:
            out = []
            for n in self.robot_names:
                points: list = []
                chart: list = []
                for k, rows in enumerate(self.rows):
                    row = rows.get(n)
                    if row is None:
                        points.append(None)
                        chart.append(None)
                        continue
                    x, y = _num(row, self._i, "x"), _num(row, self._i, "y")
                    points.append([x, y] if isinstance(x, float) and isinstance(y, float) else None)
                    chart.append([round(k * self.dt_s, 9), *(_num(row, self._i, c) for c in self.numeric)])
                out.append((points, chart))
            self._series = out
            # each robot's collisions: the tick each began and where (the page marks them, and counts)
            self._onsets = []
            for name, (points, _) in zip(self.robot_names, out):
                onsets: list[tuple[int, list]] = []
                was = False
                for tick, rows in enumerate(self.rows):
                    row = rows.get(name)
                    now = row is not None and _num(row, self._i, "collided") == 1.0
                    if now and not was and points[tick] is not None:
                        onsets.append((tick, points[tick]))
                    was = now
                self._onsets.append(onsets)
        return self._series

    def _hits(self, robot: int, after: int, upto: int) -> tuple[int, list]:
        """Collisions begun by ``upto`` (a count) and the places of those after ``after``."""
        self.series()
        onsets = self._onsets[robot]
        ticks = [t for t, _ in onsets]
        return bisect.bisect_right(ticks, upto), [p for t, p in onsets if after < t <= upto]

    def history(self) -> Json:
        """The rows before the one shown, as playing to it would have drawn them (bounded)."""
        self.jumped = False
        self._sent = self.position
        upto = self.position
        robots: list[Json] = []
        for points, chart in self.series():
            stride = max(1, math.ceil(upto / MAX_POINTS))
            path = points[:upto:stride]
            rows = series_doc([r for r in chart[:upto] if r is not None], MAX_ROWS)
            robots.append({"path": path, **rows, "hits": self._hits(len(robots), -1, upto)[1]})
        return message("history", tick=self.position, robots=robots)

    def scene(self) -> Json:
        h = self.trace.header
        robots = []
        for n in self.robot_names:
            model = MODELS.get(str(self.models.get(n)))
            robots.append(robot_doc(n, model, tuple(self.trace.columns)))
        return message(
            "scene", mode="replay", ok=True, diagnostics=[self.note] if self.note else [],
            path=self.trace.path, name=str(h.get("name", "")), dt=self.dt_s, seed=h.get("seed"),
            backend=str(h.get("backend", "?")), world=world_doc(self.world) if self.world else None,
            robots=robots, columns=[{"name": c, "group": "trace"} for c in self.numeric],
            params={k: number(v) for k, v in (h.get("params") or {}).items()}, overrides={},
            sliders=[], rules=[], states=[], stop_s=None, timeline=False, trace=self.trace.path,
            ticks=len(self.rows), end_s=round((len(self.rows) - 1) * self.dt_s, 9))

    def frame(self, take: bool = True) -> Json:
        rows = self.rows[self.position] if self.rows else {}
        robots: list[Json | None] = []
        # the rows since the last frame: their path points and chart rows (a jump sent a history)
        since = self._sent + 1 if take and self._sent < self.position else self.position
        last = since - 1 if take and self._sent < self.position else self.position  # the row the page saw last
        if take:
            self._sent = self.position
        series = self.series() if since < self.position else None
        for k, n in enumerate(self.robot_names):
            row = rows.get(n)
            if row is None:
                robots.append(None)
                continue
            between: Json = {}
            count, hits = self._hits(k, last, self.position)
            between["collisions"], between["hits"] = count, hits
            if series is not None:
                points, chart = series[k]
                thin = PathThinner()
                for q in points[since:self.position]:
                    if q is None:
                        thin.jump(math.nan, math.nan)
                    else:
                        thin.add(*q)
                path = [[x, y] if x == x else None for x, y in thin.take()]
                pending = thin.pending()
                if pending is not None:
                    path.append(list(pending))
                samples, bands = paired([r for r in chart[since:self.position] if r is not None], FRAME_ROWS)
                between |= {"path": path, "samples": samples, "bands": bands}
            model = MODELS.get(str(self.models.get(n)))
            sonars = [s.name for s in model.rays() if s.name in self._i] if model else []
            robots.append({
                "pose": [_num(row, self._i, c) for c in ("x", "y", "heading")],
                "collided": _num(row, self._i, "collided") == 1.0,
                "state": row[self._i["state"]] if "state" in self._i else "",
                "rule": (row[self._i["rule"]] or None) if "rule" in self._i else None,
                "sonars": [_num(row, self._i, s) for s in sonars],
                "values": [_num(row, self._i, c) for c in self.numeric],
                "ground": [_num(row, self._i, g.name) for g in model.ground_sensors if g.name in self._i]
                if model else [],
                **between,
            })
        first = next(iter(rows.values()), None)
        mech = self._mechanism(first) if self.world is not None and self.world.mechanism is not None else None
        labels = {c.removeprefix("label:"): first[self._i[c]] for c in self.labels} if first else {}
        return message("frame", **self.controls(), robots=robots, mechanism=mech, sliders={}, labels=labels)

    def _mechanism(self, row: list[str] | None) -> Json | None:
        """What the trace holds of a mechanism: its tracked body (the trace's x, y), the bodies
        it has ``<body>_x`` / ``<body>_z`` columns for, what is fixed to those, and the slew
        (heading); ``missing`` names the moving bodies it cannot place, which are not drawn."""
        if row is None:
            return None
        bodies: dict[str, list[float | str | None]] = {}
        for body, (cx, cz, start) in self._mech_columns.items():
            x = _num(row, self._i, cx)
            z = _num(row, self._i, cz) if cz is not None else start[1]
            if isinstance(x, float) and isinstance(z, float):
                bodies[body] = [x, z, 0.0]
        for parent, child, dx, dz in self._mech_fixed:  # a body fixed to one placed moves with it
            if parent in bodies and child not in bodies:
                px, pz, _ = bodies[parent]
                bodies[child] = [float(px) + dx, float(pz) + dz, 0.0]  # type: ignore[arg-type]
        missing = [b for b in self._mech_moving if b not in bodies]
        return {"bodies": bodies, "joints": {}, "targets": {}, "partial": True,
                "slew": _num(row, self._i, "heading"), "missing": missing,
                "note": (f"not in this trace: {', '.join(missing)} (not drawn; a rope is drawn "
                         "straight to the next body the trace places)") if missing else ""}

    def _mechanism_layout(self) -> None:
        """Which columns place which bodies of the world's mechanism (see ``_mechanism``)."""
        self._mech_columns: dict[str, tuple[str, str | None, tuple[float, float]]] = {}
        self._mech_fixed: list[tuple[str, str, float, float]] = []
        self._mech_moving: list[str] = []
        m = self.world.mechanism if self.world is not None else None
        if m is None:
            return
        lower = {c.lower(): c for c in self.numeric}
        moving = [b for b in m.bodies if not b.static]
        self._mech_moving = [b.name for b in moving]
        for k, b in enumerate(moving):
            if k == len(moving) - 1 and "x" in self._i and "y" in self._i:
                self._mech_columns[b.name] = ("x", "y", b.center)  # the body a trace tracks
                continue
            x = lower.get(f"{b.name.lower()}_x") or lower.get(f"{b.name.lower()}.x")
            z = lower.get(f"{b.name.lower()}_z") or lower.get(f"{b.name.lower()}.z")
            if x is not None:
                self._mech_columns[b.name] = (x, z, b.center)
        centre = {b.name: b.center for b in m.bodies}
        for j in m.joints:
            if j.kind == "fixed" and j.parent in centre and j.child in centre:
                (px, pz), (cx, cz) = centre[j.parent], centre[j.child]
                self._mech_fixed.append((j.parent, j.child, cx - px, cz - pz))

    mode = "replay"

    def on_seek(self, msg: dict) -> bool:
        t = msg.get("tick")
        if isinstance(t, bool) or not isinstance(t, (int, float)) or not math.isfinite(t):
            raise BadMessage("'tick' must be a number")
        self.seek(int(t))
        return False


def _num(row: list[str], index: dict[str, int], column: str) -> float | str | None:
    k = index.get(column)
    if k is None:
        return None
    cell = row[k]
    if cell in ("True", "true"):
        return 1.0
    if cell in ("False", "false"):
        return 0.0
    try:
        return number(float(cell))
    except ValueError:
        return None


def load_replay(path: str | Path, **session: Any) -> ReplaySession:
    """A replay of the trace at path; raises TraceFormatError for a damaged one."""
    trace = read_trace(path)
    if len(trace.columns) > MAX_COLUMNS:
        raise TraceFormatError(f"{len(trace.columns):,} columns: labsim view replays a trace of at most "
                               f"{MAX_COLUMNS:,} (its page could not hold more); labsim plot and "
                               "labsim.read_trace read it", str(path))
    robots = len(set(trace.column("robot"))) if "robot" in trace.columns else 0
    if robots > MAX_ROBOTS:
        raise TraceFormatError(f"{robots:,} robots: labsim view replays a trace of at most {MAX_ROBOTS:,}",
                               str(path))
    world, note = trace_world(trace)
    return ReplaySession(trace, world, note, **session)
