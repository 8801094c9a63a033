"""What a person sees during and after a run: the progress bar and the summary.

Every text that came from a file (names, labels, rules, logs, warnings) is shown inert
(``labsim.foundation.inert``): the summary goes to a teacher's terminal.
"""
from __future__ import annotations

import math
import sys
import time as clock
from typing import TextIO

from labsim.dsl.library.builtins import Aggregate
from labsim.foundation.inert import inert
from labsim.foundation.progress import StatusLine, bar
from labsim.runtime.result import RobotResult, RunResult


class ProgressBar:
    """``labsim run``'s bar: simulated time against the stop horizon, and ticks a second."""

    def __init__(self, horizon_s: float | None, stream: TextIO = sys.stderr):
        self.horizon = horizon_s
        self.line = StatusLine(stream)

    def __call__(self, tick: int, sim_time_s: float) -> None:
        if not self.line.due():
            return
        rate = tick / max(clock.perf_counter() - self.line.started, 1e-9)
        if self.horizon:
            done = min(1.0, sim_time_s / self.horizon)
            self.line.draw(f"  {bar(done)} {done:4.0%}  {sim_time_s:8.1f} / {self.horizon:.1f} s  {rate:7.0f} ticks/s")
        else:
            self.line.draw(f"  {sim_time_s:8.1f} s simulated  {rate:7.0f} ticks/s")

    def clear(self) -> None:
        self.line.clear()


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


def _robot_line(r: RobotResult) -> str:
    if r.mechanism:
        lines = [f"mechanism {inert(r.name)}"]
        lines += [f"  label {inert(slider)}: {inert(text)}" for slider, text in r.labels.items()]
        return "\n".join(lines)
    line = f"robot {inert(r.name)}: {r.contacts} collision{'s' if r.contacts != 1 else ''}"
    if r.contacts:
        line += f" ({r.contact_time_s:.2f} s in contact)"
    if r.clamped_ticks:
        line += f"; wheel commands clamped to {r.wheel_limit_rad_s:g} rad/s on {r.clamped_ticks} ticks"
    for slider, text in r.labels.items():
        line += f"\n  label {inert(slider)}: {inert(text)}"
    return line


def _fleet_table(s: RunResult) -> list[str]:
    """Metrics as a table: a row per robot and one for the fleet."""
    if not s.metric_aggregates:
        return []
    names, aggregates = list(s.metric_aggregates), list(s.metric_aggregates.values())
    header = ["metrics", *names]
    rows = [[inert(robot), *(_metric(r.metrics[n], a) for n, a in zip(names, aggregates))]
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


def format_summary(s: RunResult) -> str:
    """The text summary of a run: what ``labsim run`` prints at its end."""
    lines = [f"{inert(s.name)}  ({inert(s.path)}, {s.backend}, seed {s.seed})"]
    status = "interrupted" if s.interrupted else "done"
    rtf = f"{s.real_time_factor:,.0f}x real time" if math.isfinite(s.real_time_factor) else ""
    lines.append(f"  {status}: {s.ticks} ticks, {s.sim_time_s:.2f} s simulated in {s.wall_time_s:.2f} s"
                 + (f" ({rtf})" if rtf else ""))
    if s.stopped_by is not None:  # on the status line, so the summary keeps its layout
        first = next(iter(s.robots.values()), None)
        lines[-1] += (f"; stopped at tick {s.ticks} ({s.ticks * s.dt_s:.2f} s): '{inert(s.stop_condition)}' held for "
                      f"{'robot ' if first is not None and not first.mechanism else ''}{inert(s.stopped_by)}")
    if s.params or s.lists:
        lines += _param_lines(s)
    lines += [f"  noise: {inert(r.name)}: {inert(r.noise_text)}" for r in s.robots.values() if r.noise_text]
    if s.trace:
        lines.append(f"  trace: {inert(s.trace)}")
    if len(s.robots) == 1:
        r = next(iter(s.robots.values()))
        lines.append(_robot_line(r))
        width = max((len(m) for m in r.metrics), default=0)
        for (m, value), agg in zip(r.metrics.items(), s.metric_aggregates.values()):
            lines.append(f"  {m:<{width}}  {_metric(value, agg)}")
    else:
        lines += [_robot_line(r) for r in s.robots.values()]
        lines += _fleet_table(s)
    return "\n".join(lines + _rule_lines(s) + _fault_lines(s))


def _param_lines(s: RunResult) -> list[str]:
    """The file's parameter values; one a robot group sets for its robots, each robot's, when they differ."""
    def shown(v: float | bool) -> str:
        return str(v).lower() if isinstance(v, bool) else format(v, "g")
    robots = [r for r in s.robots.values() if not r.mechanism]
    own = {k for r in robots for k, v in r.params.items() if v != s.params.get(k)}
    each = "(each robot's below)"
    line = [f"{k}={each if k in own else shown(v)}{'*' if k in s.overridden else ''}" for k, v in s.params.items()]
    line += [f"{k}={list_text(v)}{'*' if k in s.overridden else ''}" for k, v in s.lists.items()]
    lines = ["  params: " + " ".join(line) + ("   (* set on the command line)" if s.overridden else "")]
    for k in own:
        lines.append(f"    {k}: " + " ".join(f"{inert(r.name)}={shown(r.params.get(k, s.params[k]))}" for r in robots))
    return lines


def list_text(value: tuple, limit: int = 60) -> str:
    """A list parameter as written (``[[0, -1], [3, -1]]``), its first values and how many when long."""
    items = [("[" + ", ".join(format(x, "g") for x in v) + "]") if isinstance(v, tuple) else format(v, "g")
             for v in value]
    whole = "[" + ", ".join(items) + "]"
    if len(whole) <= limit:
        return whole
    shown: list[str] = []
    while len(", ".join([*shown, items[len(shown)]])) <= limit - 20:
        shown.append(items[len(shown)])
    noun = "rows" if isinstance(value[0], tuple) else "numbers"
    return "[" + ", ".join([*shown, f"... {len(items):,} {noun}"]) + "]"


def _rule_lines(s: RunResult) -> list[str]:
    """How often each rule fired, and which never did."""
    if not s.rules:  # driven by bind: alone
        return []
    lines = ["rules (ticks fired):"]
    ids, texts = [inert(r.id) for r in s.rules], [inert(r.text) for r in s.rules]
    width = max(len(i) for i in ids)
    text_width = min(60, max(len(t) for t in texts))
    for rule, rule_id, text in zip(s.rules, ids, texts):
        text = text if len(text) <= text_width else text[:text_width - 3] + "..."
        lines.append(f"  {rule_id:<{width}}  {text:<{text_width}}  {rule.ticks:>8}")
    if s.idle_ticks:
        lines.append(f"  {'(none)':<{width}}  {'no rule held':<{text_width}}  {s.idle_ticks:>8}")
    if s.never_fired:
        lines.append(f"  never fired: {inert(', '.join(s.never_fired))}")
    return lines


def _fault_lines(s: RunResult) -> list[str]:
    """The runtime warnings, then the logs, apart: a log is what the behaviour meant to say."""
    lines = ["runtime warnings:", *(f"  {inert(f)}" for f in s.faults)] if s.faults else []
    if s.logs or s.logs_unprinted:
        lines += [f"logs: {len(s.logs)} line{'s' if len(s.logs) != 1 else ''} printed",
                  *(f"  {inert(f)}" for f in s.logs_unprinted)]
    return lines
