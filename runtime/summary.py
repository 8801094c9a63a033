"""What a run did: the ``Summary`` the tick loop hands back, and the fleet's view of a metric.

``labsim.runtime.run`` fills a ``Summary`` at the end of a run; the text summary
(``labsim.runtime.cli.report``), the JSON one (``labsim.runtime.summary_json``), goldens and
sweeps read it. Nothing here runs anything.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from labsim.dsl.builtins import Aggregate


@dataclass
class Summary:
    """What a run did; the CLI prints it, tests read it."""

    behaviour: str
    backend: str
    ticks: int
    sim_time_s: float
    wall_time_s: float
    interrupted: bool
    robots: dict[str, dict] = field(default_factory=dict)  # name -> contacts, clamps, metrics
    rule_counts: dict[str, int] = field(default_factory=dict)  # rule id -> ticks it fired
    rule_labels: dict[str, str] = field(default_factory=dict)  # rule id -> its text
    idle_ticks: int = 0  # robot-ticks on which no rule fired
    faults: list[str] = field(default_factory=list)  # "site: what (n times)"
    trace: str | None = None
    fleet: dict[str, float] = field(default_factory=dict)  # metric -> over all robots (see fleet_value)
    stopped_by: str | None = None  # the robot whose stop condition held, None if it never did
    noise: dict[str, str] = field(default_factory=dict)  # robot -> its noise models (and readings lost)
    stop_condition: str = ""  # the part of the stop condition that held ('or' parts apart)
    over_budget: str = ""  # why a budget stopped the run before its stop condition held (docs/security.md)

    @property
    def real_time_factor(self) -> float:
        return self.sim_time_s / self.wall_time_s if self.wall_time_s > 0 else math.inf


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
