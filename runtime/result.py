"""What a run did, as data: the frozen ``RunResult`` that every renderer reads.

The tick loop (``labsim.runtime.run``) hands one back from ``Run.run()`` (and a snapshot from
``Run.result()`` while it goes on); the text summary (``labsim.runtime.cli.report``), the JSON
summary (``labsim.runtime.summary_json``), a sweep's rows, goldens, the live view and the
Python API all render from it, and none of them reaches into the live ``Run``. It holds plain
values only, so a sweep's worker process can send it back pickled. Nothing here runs anything.
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

from labsim.dsl.library.builtins import Aggregate, Better

# Why a run ended (RunResult.stop_reason), as the JSON summary spells it
STOP_CONDITION, INTERRUPTED, BUDGET, MAX_TICKS = "stop condition", "interrupted", "budget", "max ticks"


@dataclass(frozen=True)
class RobotResult:
    """One robot (or the world's mechanism) at the end of a run."""

    name: str
    mechanism: bool  # the world's mechanism, driven by a behaviour without robots
    contacts: int  # collisions begun
    contact_time_s: float  # time spent touching something
    clamped_ticks: int  # ticks its wheel command exceeded the model's limit
    wheel_limit_rad_s: float | None  # None for the mechanism
    metrics: Mapping[str, float]  # metric -> its value for this robot, in the file's order
    labels: Mapping[str, str]  # slider -> its label's text at the end
    noise: Mapping[str, object] = field(default_factory=dict)  # its declared noise models (trace header form)
    noise_text: str = ""  # the noise in words, with the readings it lost ("" without noise)
    sonar_readings_lost: int = 0  # readings its sonar dropout replaced by inf
    faults: int = 0  # runtime faults (nan, inf, a domain error) in its program, all sites together
    params: Mapping[str, float | bool] = field(default_factory=dict)  # its own values, where its group sets them


@dataclass(frozen=True)
class RuleResult:
    """One rule of the file and how often it fired."""

    id: str  # "state:number"
    text: str
    ticks: int  # robot-ticks it was the rule that acted


@dataclass(frozen=True)
class RunResult:
    """A finished (or interrupted) run; see the module docstring and docs/summary-json.md."""

    # the behaviour and its settings
    name: str
    path: str
    sha256: str
    backend: str
    world: str
    dt_s: float
    seed: int
    params: Mapping[str, float | bool]
    overridden: tuple[str, ...]  # the params set on the command line
    metric_aggregates: Mapping[str, Aggregate]  # metric -> how it folds, in the file's order
    metric_better: Mapping[str, Better | None]  # metric -> which way is better (None: it declares none)
    # how it went
    ticks: int
    sim_time_s: float
    wall_time_s: float
    stop_reason: str  # STOP_CONDITION, INTERRUPTED, BUDGET or MAX_TICKS
    stopped_by: str | None = None  # the robot whose stop condition held
    stop_condition: str = ""  # the part of the stop condition that held ('or' parts apart)
    over_budget: str = ""  # why a budget stopped the run (docs/security.md)
    # what it did
    robots: Mapping[str, RobotResult] = field(default_factory=dict)
    fleet: Mapping[str, float] = field(default_factory=dict)  # metric -> over all robots (fleet_value)
    rules: tuple[RuleResult, ...] = ()
    idle_ticks: int = 0  # robot-ticks on which no rule held
    faults: tuple[str, ...] = ()  # "site: what: n times (first at tick t, robot r)"
    warnings: tuple[str, ...] = ()  # the compiler's warnings (one line each), then the run's own
    logs: tuple[str, ...] = ()  # what log(...) printed, apart from the warnings
    logs_unprinted: tuple[str, ...] = ()  # "log on line L: n lines not printed (...)", per line; then the run's cap
    trace: str | None = None  # where its trace was written
    lists: Mapping[str, tuple] = field(default_factory=dict)  # list parameters after --set (format 1.3)

    @property
    def interrupted(self) -> bool:
        """Ctrl-C (or a trace the system refused to write) ended it before its stop condition."""
        return self.stop_reason == INTERRUPTED

    @property
    def real_time_factor(self) -> float:
        return self.sim_time_s / self.wall_time_s if self.wall_time_s > 0 else math.inf

    @property
    def rule_counts(self) -> dict[str, int]:
        """Rule id -> ticks it fired, in the file's order."""
        return {r.id: r.ticks for r in self.rules}

    @property
    def never_fired(self) -> list[str]:
        return [r.id for r in self.rules if r.ticks == 0]

    def metric_values(self) -> dict[str, float]:
        """The run's value of each metric: the robot's own for one robot, the fleet's for more."""
        if len(self.robots) == 1:
            return dict(next(iter(self.robots.values())).metrics)
        return dict(self.fleet)


def fleet_value(aggregate: Aggregate, values: list[float]) -> float:
    """A metric over the whole fleet from the robots' values.

    Counts and durations add up (total events, robot-seconds); maximum and minimum take the
    extreme; rms is the root mean square of the robots' values; mean and final average.
    """
    finite = [v for v in values if v == v]
    if not finite:
        return math.nan
    if aggregate in (Aggregate.COUNT, Aggregate.DURATION):
        return sum(finite)
    if aggregate is Aggregate.MAXIMUM:
        return max(finite)
    if aggregate is Aggregate.MINIMUM:
        return min(finite)
    if aggregate is Aggregate.RMS:
        return math.sqrt(sum(v * v for v in finite) / len(finite))
    return sum(finite) / len(finite)
