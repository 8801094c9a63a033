"""A live run to watch and steer: the same compiled behaviour, backend and tick loop as ``labsim run``.

``LiveSession`` compiles the behaviour (with the ``--set`` overrides and ``--seed``), binds
it to the chosen backend through an ``ObservedBackend`` (what the page draws), and ticks the
``Run`` when the server says ticks are due. A slider drag is ``Run.set_slider``, so it lands
in the trace's events column as a timeline move does; a parameter change recompiles with the
new overrides (the same checks as ``--set``) and restarts. A file that does not compile
leaves the session without a run and its diagnostics in ``problems``, for the terminal and
the page; ``recheck`` tries again.
"""
from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager, nullcontext
from dataclasses import replace
from pathlib import Path
from typing import Any

from labsim.backends import load_backend
from labsim.backends.protocol import BackendError
from labsim.dsl.library.support import metric_result
from labsim.foundation.diagnostics import Diagnostic, LabsimError
from labsim.foundation.files import check_output, read_text
from labsim.foundation.inert import inert
from labsim.foundation.limits import DEFAULT_BUDGETS, Budgets
from labsim.foundation.memory import memory_cap, out_of_memory
from labsim.runtime.budgets import out_of_memory_message
from labsim.runtime.observers import hooks
from labsim.runtime.run import Behaviour, Run, compile_behaviour
from labsim.runtime.tick import make_tick
from labsim.runtime.view.breaks import MAX_BREAKPOINTS, Breakpoint, parse_break
from labsim.runtime.view.edits import edited_text, save_over, wanted_params
from labsim.runtime.view.frames import (
    Json,
    channel_kinds,
    message,
    number,
    part,
    png_data_url,
    robot_doc,
    sensor_columns,
    short,
    shown_values,
    value_columns,
    value_slots,
    world_doc,
)
from labsim.runtime.view.hands import block_message, blocks_doc, place_message
from labsim.runtime.view.history import History
from labsim.runtime.view.observe import ObservedBackend
from labsim.runtime.view.peaks import Sampler
from labsim.runtime.view.record import TickRecorder
from labsim.runtime.view.session import BadMessage, ChangeRefused, Session, finite, name

SAMPLE_NUMBERS = 180  # chart numbers a frame carries at most, all robots together (a frame < 4 KB with the path)


class LiveSession(Session):
    """See the module docstring. ``warn`` takes the run's runtime warnings."""

    def __init__(self, path: str | Path, overrides: dict[str, str], *, seed: int | None = None,
                 backend: str = "pymunk", backend_options: dict[str, object] | None = None,
                 trace: str | Path | None = None, warn: Callable[[str], None] | None = None,
                 timeline: bool = True, budgets: Budgets = DEFAULT_BUDGETS, breaks: list[str] | None = None,
                 read_only: bool = False, **session: Any):
        super().__init__(0.05, **session)
        self.path = str(path)
        self.overrides = dict(overrides)
        self.seed = seed
        self.backend_name = backend
        self.backend_options = dict(backend_options or {})
        self.trace_path = trace
        self.warn = warn
        self.timeline = timeline
        self.budgets = budgets  # --budget: the live runs' sizes and memory (no tick budget: a person stops it)
        self.run: Run | None = None
        self.observed: ObservedBackend | None = None
        self.problems: list[Diagnostic] = []  # the file's warnings, or why there is no run
        self.refused: list[Diagnostic] = []  # why the last change did not compile
        self.ever_ran = False
        self.breaks = list(breaks or [])  # as written: compiled anew for every run
        self.read_only = read_only  # no editing the file in the page
        self.can_save = True  # False without a session token (--no-token): anyone could write the file
        self.text: str | None = None  # the page's edit the run was compiled from, not yet saved
        self._capped = False  # inside ticking(): the memory cap is set

    # -- the run ------------------------------------------------------------------------
    def load(self, overrides: dict[str, str] | None = None) -> bool:
        """Compile and bind anew (the old run, if any, is closed only once the new one compiles).

        False, with ``problems`` set, when the file (or an override) has errors; the old run
        then goes on.
        """
        wanted = self.overrides if overrides is None else overrides
        try:
            behaviour = compile_behaviour(self.path, wanted, seed=self.seed, text=self.text, budget=self.budgets)
            if self.trace_path:  # the world may have changed with the file: never write over it
                check_output(self.trace_path, [self.path, behaviour.program.world.source], "--trace")
            breaks = [parse_break(behaviour.program, b) for b in self.breaks]
        except LabsimError as e:
            self.refused = list(e.diagnostics)
            if self.run is None:
                self.problems = self.refused
            return False
        self.overrides = dict(wanted)
        self.close()
        try:
            self._bind(behaviour, breaks)
        except (LabsimError, BackendError) as e:
            self.run = None
            self.problems = list(e.diagnostics) if isinstance(e, LabsimError) else [Diagnostic(self.path, str(e))]
            return False
        self.problems = list(behaviour.program.warnings)
        self.ever_ran = True
        return True

    def _bind(self, behaviour: Behaviour, breaks: list[Breakpoint]) -> None:
        program = behaviour.program
        self.observed = ObservedBackend(load_backend(self.backend_name, **self.backend_options), program.channels)
        self.recorder = TickRecorder()
        self.recorder.breaks = breaks
        self.run = run = behaviour.bind(self.observed, trace=self.trace_path, warn=self.warn,
                                  replay=None if self.timeline else {}, watch=True, observers=[self.recorder])
        # where each robot's x and y sit in its readings: known once the backend is open
        self.recorder.start([(at["x"], at["y"], at["collided"]) if r.model is not None else None
                             for r, at in zip(self.run.robots, self.observed.index)], self.observed.last)
        self.pacer.dt_s = program.dt_s
        self.history_kept = History(len(run.robots))
        self.pacer.anchor(self.clock(), 0)
        self.playing = False
        kinds = channel_kinds(program.world, self.run.robots[0].model if self.run.robots else None)
        self._sensors = sensor_columns(program.channels, kinds)
        self._lets, numeric, self._states_read = value_slots(program)
        self._state_slot = program.slot_of["state"]
        self._sample_slots = self._lets + [program.slot_of[n] for n in program.slider_names]
        self._sampler = Sampler(self._sensors, [s if ok else None for s, ok in zip(self._sample_slots, numeric)])
        self.recorder.chart(self._sampler.read, self._sampler.keep, self._sampler.width, self._sampler.columns)
        given = hooks(run.observers)
        run.tick = make_tick(run, given)  # the recorder's hook, generated for these columns
        # and a tick without the inputs' hook, for stretches with no move to apply (``Inputs.quiet``),
        # its recorder's hook one that does not look for one (``TickRecorder.quiet_act``)
        moves, rec = getattr(run.inputs, "before_tick", None), self.recorder
        self._quiet = make_tick(run, replace(given, before_tick=tuple(h for h in given.before_tick if h != moves),
                                             after_act=tuple(rec.quiet_act if h == rec.after_act else h
                                                             for h in given.after_act)))
        self._sonars = [[program.channels.index(s.name) for s in r.model.rays() if s.name in program.channels]
                        if r.model is not None else [] for r in self.run.robots]
        self._cameras = [[program.channels.index(c.name) for c in r.model.cameras if c.name in program.channels]
                         if r.model is not None else [] for r in self.run.robots]
        self._ground = [[program.channels.index(g.name) for g in r.model.ground_sensors if g.name in program.channels]
                        if r.model is not None else [] for r in self.run.robots]

    @property
    def tick(self) -> int:
        return self.run.tick_index if self.run is not None else 0

    @property
    def shown_tick(self) -> int:
        # the pose, readings, rule and state a frame shows are those of the last tick run, as the
        # trace's row of that tick has them (``tick`` counts the ticks run: one more)
        return max(0, self.tick - 1)

    @property
    def ran(self) -> int:
        return self.tick

    @property
    def finished(self) -> bool:
        return self.run is None or self.run.finished

    def advance(self, n: int) -> int:
        run = self.run
        if run is None:
            return 0
        tick, rec = run.tick, self.recorder
        if run.inputs is not None and run.inputs.quiet(run.tick_index, n):
            tick = self._quiet  # a call less a tick
        rec.hit = None  # Play or Step goes on from a breakpoint
        k = 0
        try:  # the run's backstop, as Run.run has it (set by ticking() when catching up)
            with nullcontext() if self._capped else memory_cap(run.budgets.memory_mb):
                for k in range(n):
                    if not tick():
                        if run.trace is not None:
                            run.end_trace()  # the stop condition held: the trace is complete
                        return k
                    if rec.hit is not None:  # a breakpoint held on this tick: pause on it
                        self.playing = False
                        return k + 1
        except Exception as e:  # running out of memory ends the run with labsim's message; the page stays
            if not out_of_memory(e):
                raise
            run.over_budget = out_of_memory_message(run.budgets.memory_mb, run.tick_index)
            run.finished = True
            if self.warn is not None:
                self.warn(f"{inert(self.path)}: error: {run.over_budget}")
            return k
        return n

    @contextmanager
    def ticking(self) -> Iterator[object]:
        # reading the process's size and setting a limit costs a file read and two system
        # calls: once a frame, not once every CHECK_EVERY ticks (it was a tenth of a tick's time)
        if self.run is None or self._capped:
            yield None
            return
        with memory_cap(self.run.budgets.memory_mb):
            self._capped = True
            try:
                yield None
            finally:
                self._capped = False

    def restart(self) -> None:
        self.load()

    def close(self) -> None:
        if self.run is not None:
            self.run.close()
            self.run = None

    # -- documents ------------------------------------------------------------------------
    def scene(self) -> Json:
        problems = [d.format() for d in self.problems]
        if self.run is None:
            return message("scene", mode="live", path=self.path, ok=False, diagnostics=problems, **self._source())
        p = self.run.program
        columns = ([{"name": c, "group": "sensor"} for c, _, _ in self._sensors]
                   + value_columns(p)
                   + [{"name": n, "group": "slider"} for n in p.slider_names]
                   + [{"name": n, "group": "metric"} for n in p.metric_names])
        start = {n: v for n, v in zip(p.slider_names, self._slider_values())}
        return message(
            "scene", mode="live", ok=True, diagnostics=problems, path=p.path, name=p.name, dt=p.dt_s,
            seed=p.seed, backend=self.observed.name if self.observed else "?", world=world_doc(p.world),
            robots=[robot_doc(r.name, r.model, p.channels) for r in self.run.robots],
            columns=columns, params={k: number(v) for k, v in p.params.items()},
            overrides=self.overrides, counts=self.recorder.count_names,
            sliders=[{"name": n, "min": lo, "max": hi, "value": start[n], "label": p.label_of(n)}
                     for n, (lo, hi) in p.slider_ranges.items()],
            rules=[{"id": r.id, "text": r.text, "state": r.state} for r in p.rules],
            states=list(p.state_names), stop_s=p.stop_horizon_s, timeline=self.timeline,
            trace=str(self.trace_path) if self.trace_path else None, **self._source())

    def _source(self) -> Json:
        """The scene's editor fields: the text the run was compiled from, whether it differs from
        the file (an edit applied, not saved), and whether the page may edit at all."""
        text = self.text
        if text is None:
            try:
                text = read_text(self.path)
            except LabsimError:
                text = None
        return {"source": text, "edited": self.text is not None, "read_only": self.read_only,
                "can_save": self.can_save and not self.read_only}

    def _slider_values(self) -> list[float]:
        assert self.run is not None
        p = self.run.program
        slots = self.run.robots[0].program.slots
        return [slots[p.slot_of[n]] for n in p.slider_names]

    def history(self) -> Json:
        if self.run is None:
            return super().history()
        return self.history_kept.doc(self.shown_tick)

    def frame(self, take: bool = True) -> Json:
        """One moment of the run: see docs/view.md, "frame"; ``take`` False: see ``Session.frame``."""
        if self.run is None:
            return message("frame", **self.controls(), robots=[], mechanism=None, sliders={}, labels={})
        run, obs = self.run, self.observed
        assert obs is not None
        p = run.program
        # each robot's metrics so far, as the run's result has them (not the whole result: a tenth of a frame)
        metrics = {r.name: [number(metric_result(agg, acc, p.dt_s)) for agg, acc in
                            zip(p.metric_aggregates, r.program.metric_values)] for r in run.robots}
        robots = []
        rec, dt, ended = self.recorder, p.dt_s, take and run.finished and run.stopped_by is not None
        paths = [[[short(x), short(y)] for x, y in rec.take_path(r.index)] if take else [] for r in run.robots]
        events = self.history_kept.frame_events(rec.take_events()) if take else {"events": []}
        left = max(SAMPLE_NUMBERS // 2, SAMPLE_NUMBERS - 2 * sum(len(q) for q in paths) // 3  # chart: < 4 KB
                   - sum(len(e[2]) + len(e[3]) + 24 for e in events["events"]) // 8)  # a number ~8 bytes
        per = max(2, left // max(1, len(run.robots) * (len(self._sensors) + len(self._lets) + 1)))
        for r in run.robots:  # once stopped, the last tick that acted: its signals, not the stopping tick's
            slots = self._sampler.as_of(rec.samples[r.index], r.program.slots, self.shown_tick) \
                if ended else r.program.slots
            read, done = (obs.last[r.index] if obs.last else None), metrics[r.name]
            values = self._values(read, slots) + done
            rule = run.last_rule[r.index]
            pose = self._pose(r.index, r.start) if r.model is not None else None
            hits: list = [[short(x), short(y)] for x, y in rec.hits[r.index]] if take else []
            path: list = paths[r.index]
            charted = [short(v) for v in done]  # four decimals as the rest of a chart row (5 robots: < 4 KB)
            samples: list = [[*row, *charted] for row in self._sampler.rows(rec.take_samples(r.index), dt, per)] \
                if take else []
            robots.append({
                "pose": pose,
                "collided": bool(obs.reading(r.index, "collided")) if r.model is not None else False,
                "state": p.state_names[self._state_of(r.index, slots)] if p.state_names else "",
                "rule": p.rules[rule].id if rule >= 0 else None,
                "sonars": [number(read[i]) if read is not None else None for i in self._sonars[r.index]],
                "ground": [number(read[i]) if read is not None else None for i in self._ground[r.index]],
                "collisions": rec.collisions[r.index],
                "hits": hits, "marks": self.history_kept.marked(r.index, rec.marks, take),
                "values": values,
                "path": path,
                "samples": samples, "bands": self._sampler.bands if samples and self._sampler.paired else None,
            })
            if take:  # what this frame draws, for the pages that open later
                rec.hits[r.index] = []
                self.history_kept.hits[r.index] += hits
                self.history_kept.add(r.index, path + ([pose[:2]] if pose is not None else []),
                                      samples + ([[round(self.shown_tick * dt, 9), *values]] if self.ran else []),
                                      self._sampler.bands if samples and self._sampler.paired else None)
        first = run.robots[0].program.slots if run.robots else []
        blocks = blocks_doc(run)
        changed = {"blocks": blocks} if blocks is not None else {}  # moved by hand: the scene's are old
        return message("frame", **self.controls(), why=run.stop_reason() if run.finished else None,
                       robots=robots, mechanism=self._mechanism(), **changed,
                       breakpoints=self.breaks, hit=rec.hit, edited=self.text is not None,
                       **events,
                       sliders=dict(zip(p.slider_names, self._slider_values())),
                       labels=p.label_text(first) if p.labels else {})

    def _state_of(self, robot: int, slots: list) -> int:
        """The state of the tick shown (a goto on it takes effect on the next), or the first."""
        state = self.recorder.states[robot]
        return int(slots[self._state_slot] if state is None else state)

    def _values(self, read: list | None, slots: list) -> list[float | str | None]:
        """A robot's sensor, signal and slider columns from one tick's readings and slots."""
        p = self.run.program if self.run is not None else None
        assert p is not None
        values = [part(read[i], k) if read is not None else None for _, i, k in self._sensors]
        values += shown_values(slots, self._lets, self._states_read, p.state_names)
        values += [number(slots[p.slot_of[n]]) for n in p.slider_names]
        return values

    def _pose(self, robot: int, start: Any) -> list[float | str | None]:
        obs = self.observed
        assert obs is not None
        if not obs.last or obs.last[robot] is None:
            return [number(start.x_m), number(start.y_m), number(start.heading_rad)]
        return [number(obs.reading(robot, c)) for c in ("x", "y", "heading")]

    def _mechanism(self) -> Json | None:
        assert self.run is not None and self.observed is not None
        world = self.run.program.world
        m = world.mechanism
        if m is None or not self.run.robots or self.run.robots[0].model is not None:
            return None
        obs = self.observed
        bodies = {}
        for b in m.bodies:
            if not b.static:
                pose = obs.reading(0, b.name)
                if isinstance(pose, tuple):
                    bodies[b.name] = [number(v) for v in pose]
        joints = {}
        for j in m.joints:
            value = obs.reading(0, j.name) if j.kind != "fixed" else None
            if isinstance(value, tuple):
                joints[j.name] = [number(v) for v in value]
        return {"bodies": bodies, "joints": joints,
                "targets": {k: [mode, number(v)] for k, (mode, v) in obs.targets.items()}}

    def images(self, robot: int) -> Json | None:
        run, obs = self.run, self.observed
        if run is None or obs is None or not obs.last or not 0 <= robot < len(run.robots):
            return None
        read = obs.last[robot]
        if read is None:
            return None
        out: Json = {"robot": robot, "camera": None, "derived": []}
        for i in self._cameras[robot]:
            out["camera"] = png_data_url(read[i])
        slots = run.robots[robot].program.slots
        for n in run.program.single_signals:
            url = png_data_url(slots[run.program.slot_of[n]])
            if url is not None:
                out["derived"].append([n, url])
        return out if out["camera"] or out["derived"] else None

    # -- messages -------------------------------------------------------------------------
    def on_slider(self, msg: dict) -> bool:
        self._slider(msg)
        return False

    def on_params(self, msg: dict) -> bool:
        return self._params(msg)

    def on_timeline(self, msg: dict) -> bool:
        on = msg.get("on")
        if not isinstance(on, bool):
            raise BadMessage("'on' must be true or false")
        self.timeline = on
        return self.load()

    def on_recheck(self, msg: dict) -> bool:
        self.load()
        return True

    def on_break(self, msg: dict) -> bool:
        self._break(msg)
        return False

    def on_place(self, msg: dict) -> bool:
        self._need_run()
        assert self.run is not None
        robot, x, y = place_message(self.run, msg)
        self.recorder.paths[robot].jump(x, y)
        return False

    def on_block(self, msg: dict) -> bool:
        self._need_run()
        assert self.run is not None
        block_message(self.run, msg)
        return False

    def on_apply(self, msg: dict) -> bool:
        return self._edit("apply", msg)

    def on_save(self, msg: dict) -> bool:
        return self._edit("save", msg)

    def _need_run(self) -> None:
        if self.run is None:
            raise BadMessage("there is no run to change")

    def _slider(self, msg: dict) -> None:
        slider = name(msg.get("name"), "name")
        value = finite(msg.get("value"), "value")
        if self.run is None:
            raise BadMessage("there is no run to move a slider in")
        if slider not in self.run.program.slider_ranges:
            raise BadMessage(f"no slider '{slider}'")
        self.run.set_slider(slider, value)

    def _edit(self, kind: str, msg: dict) -> bool:
        """Apply the page's text (compile it; restart with it when it compiles, else keep the run
        and say why, with lines and columns), or save it over the file the view was opened with."""
        text = edited_text(msg)
        if self.read_only:
            raise ChangeRefused([f"{self.path}: this view is read-only (labsim view --read-only)"])
        if kind == "save":
            self._save(text)
            return False
        before = self.text
        self.text = text
        if self.load():
            return True
        self.text = before
        raise ChangeRefused([d.format() for d in self.refused],
                            [{"line": d.line, "col": d.col, "message": d.message, "severity": d.severity}
                             for d in self.refused if d.path == self.path])

    def _save(self, text: str) -> None:
        """Write the text over the view's own file, atomically (never over its world or trace,
        never through a link)."""
        inputs = [self.run.program.world.source] if self.run is not None and self.run.program.world.source else []
        save_over(str(self.path), text, [*inputs, *([self.trace_path] if self.trace_path else [])], self.can_save)
        if self.text == text:
            self.text = None  # the file holds what runs

    def _break(self, msg: dict) -> None:
        """Add a breakpoint (checked against this run's program) or remove one by its index."""
        if self.run is None:
            raise BadMessage("there is no run to set a breakpoint in")
        if "remove" in msg:
            k = msg["remove"]
            if isinstance(k, bool) or not isinstance(k, int) or not 0 <= k < len(self.breaks):
                raise BadMessage("'remove' must be a breakpoint's index")
            del self.breaks[k]
            del self.recorder.breaks[k]
            return
        spec = msg.get("add")
        if not isinstance(spec, str) or not spec.strip() or len(spec) > 500:
            raise BadMessage("'add' must be a breakpoint, as --break takes it")
        if len(self.breaks) >= MAX_BREAKPOINTS:
            raise ChangeRefused([f"at most {MAX_BREAKPOINTS} breakpoints"])
        try:
            b = parse_break(self.run.program, spec, "breakpoint")
        except LabsimError as e:
            raise ChangeRefused([d.format() for d in e.diagnostics]) from None
        self.breaks.append(b.spec)
        self.recorder.breaks.append(b)

    def _params(self, msg: dict) -> bool:
        wanted = wanted_params(msg, self.overrides)
        ok = self.load(wanted)
        if not ok:  # the page's Parameters panel, not the command line's --set, said it
            self.refused = [replace(d, path="Parameters, " + d.path.removeprefix("--set ").replace("=", " = ", 1))
                            if d.path.startswith("--set ") else d for d in self.refused]
        return True if ok else self._failed()

    def _failed(self) -> bool:
        """A change that did not compile: the page gets the diagnostics, the run goes on."""
        raise ChangeRefused([d.format() for d in self.refused])

