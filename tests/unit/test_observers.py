"""Observers of the tick core (runtime/observers.py, runtime/tick.py), tick by tick against a
scripted backend: which hooks run when, in what order, and that a run's result is data."""
from __future__ import annotations

import dataclasses
import pickle

import pytest
from fake_backend import FakeBackend

from labsim.runtime.observers import Observer
from labsim.runtime.result import RunResult
from labsim.runtime.run import compile_behaviour

HEAD = "labsim: 1.1\nworld: walls_lab4\ndt: 0.5\nseed: 3\nrobots:\n  p: {model: pioneer_p3dx, at: [0, 0, 0]}\n"
RULES = "stop: sonar5 <= 0.5\nrules:\n  - if sonar2 <= 0.5 then stop()\n  - else move(3)\n"
#               tick:  0    1    2    3
SCRIPT = {"sonar5": [1.0, 1.0, 1.0, 0.4], "sonar2": [1.0, 0.1, 1.0, 1.0]}


class Recorder(Observer):
    """Writes down every hook call as (hook, tick, robot, rule)."""

    def __init__(self) -> None:
        self.calls: list[tuple] = []

    def bind(self, run) -> None:
        self.run = run
        self.calls.append(("bind", run.tick_index))

    def before_tick(self, tick: int) -> None:
        self.calls.append(("before", tick))

    def after_act(self, robot, rule: int, values: list) -> None:
        self.calls.append(("after", self.run.tick_index, robot.name, rule))

    def at_stop(self, robot, values: list) -> None:
        self.calls.append(("stop", self.run.tick_index, robot.name))


class BeforeOnly(Observer):
    def __init__(self) -> None:
        self.ticks: list[int] = []

    def before_tick(self, tick: int) -> None:
        self.ticks.append(tick)


def test_each_hook_runs_once_per_tick_in_order_and_the_stopping_tick_is_shown(write) -> None:
    rec = Recorder()
    run = compile_behaviour(write(HEAD + RULES)).bind(FakeBackend(SCRIPT), observers=[rec])
    result = run.run(max_ticks=10)
    assert result.ticks == 3 and result.stop_reason == "stop condition"
    assert rec.calls == [
        ("bind", 0),
        ("before", 0), ("after", 0, "p", 1),  # rule index 1 is main:2 (else move)
        ("before", 1), ("after", 1, "p", 0),
        ("before", 2), ("after", 2, "p", 1),
        ("before", 3), ("stop", 3, "p"),  # format 1.1: the stopping tick is shown, no rule acts
    ]


def test_a_fleet_calls_after_act_per_robot_after_every_robot_was_sensed(write) -> None:
    head = HEAD.replace("p: {model: pioneer_p3dx, at: [0, 0, 0]}", "p: {model: pioneer_p3dx, count: 2, at: random}")
    rec = Recorder()
    compile_behaviour(write(head + RULES)).bind(FakeBackend(SCRIPT), observers=[rec]).run(max_ticks=10)
    assert rec.calls[1:4] == [("before", 0), ("after", 0, "p[0]", 1), ("after", 0, "p[1]", 1)]
    assert rec.calls[-2:] == [("stop", 3, "p[0]"), ("stop", 3, "p[1]")]


def test_an_observer_with_only_a_pre_tick_hook_leaves_the_run_as_it_was(write) -> None:
    behaviour = compile_behaviour(write(HEAD + RULES))
    plain, seen = FakeBackend(SCRIPT), FakeBackend(SCRIPT)
    a = behaviour.bind(plain).run(max_ticks=10)
    watcher = BeforeOnly()
    b = compile_behaviour(write(HEAD + RULES)).bind(seen, observers=[watcher]).run(max_ticks=10)
    assert watcher.ticks == [0, 1, 2, 3]
    assert plain.acts == seen.acts
    assert dataclasses.replace(a, wall_time_s=0.0) == dataclasses.replace(b, wall_time_s=0.0)


def test_watch_keeps_the_last_rule_of_each_robot(write) -> None:
    run = compile_behaviour(write(HEAD + RULES)).bind(FakeBackend(SCRIPT), watch=True)
    assert run.last_rule == [-1]
    run.tick()
    assert run.last_rule == [1]
    run.tick()
    assert run.last_rule == [0]


def test_the_result_is_frozen_data_that_survives_pickling(write) -> None:
    result = compile_behaviour(write(HEAD + RULES)).bind(FakeBackend(SCRIPT)).run(max_ticks=10)
    assert isinstance(result, RunResult)
    with pytest.raises(dataclasses.FrozenInstanceError):
        result.ticks = 0  # type: ignore[misc]
    again = pickle.loads(pickle.dumps(result))
    assert again == result and again.rule_counts == {"main:1": 1, "main:2": 2}
    assert again.robots["p"].wheel_limit_rad_s is not None and again.stopped_by == "p"


def test_log_lines_are_kept_apart_from_the_warnings(write) -> None:
    body = ("stop: tick >= 3\nrules:\n  - if sonar2 <= 0.5 then log('near {sonar2}'), stop()\n"
            "  - if sonar5 > 9 then move(1 / 0)\n  - else move(3)\n")
    script = {"sonar5": [1.0, 10.0, 1.0], "sonar2": [0.2, 1.0, 1.0]}
    warned: list[str] = []
    result = compile_behaviour(write(HEAD + body)).bind(FakeBackend(script), warn=warned.append).run(max_ticks=10)
    assert result.logs == ("[0.00 s] p: near 0.2",)
    assert result.warnings and all("near" not in w for w in result.warnings)
    assert warned[0] == result.logs[0]  # without a log sink, logs are printed where warnings are
    assert result.robots["p"].faults == 3  # 1 / 0, then an infinite command to each wheel
