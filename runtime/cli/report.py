"""What a person sees during and after a run: the progress bar and the summary."""
from __future__ import annotations

import math
import sys
import time as clock
from typing import TextIO

from labsim.dsl.builtins import Aggregate
from labsim.runtime.run import Run
from labsim.runtime.summary import Summary


class ProgressBar:
    """A one-line bar on a terminal, redrawn at most ten times a second."""

    def __init__(self, horizon_s: float | None, stream: TextIO = sys.stderr):
        self.horizon = horizon_s
        self.stream = stream
        self.started = clock.perf_counter()
        self.last = 0.0
        self.drawn = False

    def __call__(self, tick: int, sim_time_s: float) -> None:
        now = clock.perf_counter()
        if now - self.last < 0.1:
            return
        self.last = now
        rate = tick / max(now - self.started, 1e-9)
        if self.horizon:
            done = min(1.0, sim_time_s / self.horizon)
            bar = "#" * int(done * 30)
            text = f"\r  [{bar:<30}] {done:4.0%}  {sim_time_s:8.1f} / {self.horizon:.1f} s  {rate:7.0f} ticks/s"
        else:
            text = f"\r  {sim_time_s:8.1f} s simulated  {rate:7.0f} ticks/s"
        self.stream.write(text)
        self.stream.flush()
        self.drawn = True

    def clear(self) -> None:
        if self.drawn:
            self.stream.write("\r" + " " * 78 + "\r")
            self.stream.flush()


def _metric(value: float, aggregate: Aggregate) -> str:
    if aggregate is Aggregate.COUNT:
        return f"{value:g}"
    if aggregate is Aggregate.DURATION:
        return f"{value:.2f} s"
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    return f"{value:.4g}"


def _robot_line(name: str, r: dict, run: Run) -> str:
    if r.get("mechanism"):
        lines = [f"mechanism {name}"]
        lines += [f"  label {slider}: {text}" for slider, text in r["labels"].items()]
        return "\n".join(lines)
    limit = next(x.limit for x in run.robots if x.name == name)
    contacts = r["contacts"]
    line = f"robot {name}: {contacts} collision{'s' if contacts != 1 else ''}"
    if contacts:
        line += f" ({r['contact_time_s']:.2f} s in contact)"
    if r["clamped_ticks"]:
        line += f"; wheel commands clamped to {limit:g} rad/s on {r['clamped_ticks']} ticks"
    for slider, text in r.get("labels", {}).items():
        line += f"\n  label {slider}: {text}"
    return line


def _fleet_table(s: Summary, names: tuple[str, ...], aggregates: tuple[Aggregate, ...]) -> list[str]:
    """Metrics as a table: a row per robot and one for the fleet."""
    if not names:
        return []
    header = ["metrics", *names]
    rows = [[robot, *(_metric(r["metrics"][n], a) for n, a in zip(names, aggregates))]
            for robot, r in s.robots.items()]
    rows.append(["fleet", *(_metric(s.fleet[n], a) + _FLEET_MARK[a] for n, a in zip(names, aggregates))])
    widths = [max(len(row[i]) for row in [header, *rows]) for i in range(len(header))]
    out = ["  " + "  ".join(c.ljust(w) if i == 0 else c.rjust(w) for i, (c, w) in enumerate(zip(row, widths)))
           for row in [header, *rows]]
    out.append("  (fleet: + total over robots, ^ highest, _ lowest, ~ mean of the robots, "
               "rms of the robots' values)")
    return out


_FLEET_MARK = {Aggregate.COUNT: "+", Aggregate.DURATION: "+", Aggregate.MAXIMUM: "^", Aggregate.MINIMUM: "_",
               Aggregate.MEAN: "~", Aggregate.FINAL: "~", Aggregate.RMS: ""}


def format_summary(s: Summary, run: Run) -> str:
    p = run.program
    lines = [f"{p.name}  ({p.path}, {s.backend}, seed {p.seed})"]
    status = "interrupted" if s.interrupted else "done"
    rtf = f"{s.real_time_factor:,.0f}x real time" if math.isfinite(s.real_time_factor) else ""
    lines.append(f"  {status}: {s.ticks} ticks, {s.sim_time_s:.2f} s simulated in {s.wall_time_s:.2f} s"
                 + (f" ({rtf})" if rtf else ""))
    if s.stopped_by is not None:  # on the status line, so the summary keeps its layout
        lines[-1] += (f"; stopped at tick {s.ticks} ({s.ticks * p.dt_s:.2f} s): '{s.stop_condition}' held for "
                      f"{'robot ' if run.robots[0].model is not None else ''}{s.stopped_by}")
    if p.params:
        shown = [f"{k}={str(v).lower() if isinstance(v, bool) else format(v, 'g')}"
                 f"{'*' if k in p.overridden else ''}" for k, v in p.params.items()]
        lines.append("  params: " + " ".join(shown) + ("   (* set on the command line)" if p.overridden else ""))
    if s.noise:
        lines += [f"  noise: {robot}: {text}" for robot, text in s.noise.items()]
    if s.trace:
        lines.append(f"  trace: {s.trace}")
    if len(s.robots) == 1:
        for name, r in s.robots.items():
            lines.append(_robot_line(name, r, run))
            width = max((len(m) for m in r["metrics"]), default=0)
            for (m, value), agg in zip(r["metrics"].items(), p.metric_aggregates):
                lines.append(f"  {m:<{width}}  {_metric(value, agg)}")
    else:
        lines += [_robot_line(name, r, run) for name, r in s.robots.items()]
        lines += _fleet_table(s, p.metric_names, p.metric_aggregates)
    if not s.rule_counts:  # driven by bind: alone
        return "\n".join(lines + _fault_lines(s))
    lines.append("rules (ticks fired):")
    ids = list(s.rule_counts)
    width = max((len(i) for i in ids), default=0)
    text_width = min(60, max((len(t) for t in s.rule_labels.values()), default=0))
    never = []
    for rid in ids:
        n = s.rule_counts[rid]
        text = s.rule_labels[rid]
        if len(text) > text_width:
            text = text[:text_width - 3] + "..."
        lines.append(f"  {rid:<{width}}  {text:<{text_width}}  {n:>8}")
        if n == 0:
            never.append(rid)
    if s.idle_ticks:
        lines.append(f"  {'(none)':<{width}}  {'no rule held':<{text_width}}  {s.idle_ticks:>8}")
    if never:
        lines.append(f"  never fired: {', '.join(never)}")
    return "\n".join(lines + _fault_lines(s))


def _fault_lines(s: Summary) -> list[str]:
    return ["runtime warnings:", *(f"  {f}" for f in s.faults)] if s.faults else []
