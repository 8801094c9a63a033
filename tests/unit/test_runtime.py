"""The tick loop, tick by tick, against a scripted backend."""
from __future__ import annotations

import math

from fake_backend import FakeBackend

from labsim.backends import load_backend
from labsim.runtime.cli.main import main
from labsim.runtime.run import compile_behaviour
from labsim.runtime.trace import read_trace

HEAD = "labsim: 1\nworld: walls_lab4\ndt: 0.5\nseed: 3\nrobots:\n  p: {model: pioneer_p3dx, at: [0, 0, 0]}\n"


def run(write, body: str, script, ticks: int = 100, trace=None, warn=None):
    behaviour = compile_behaviour(write(HEAD + body))
    backend = FakeBackend(script)
    r = behaviour.bind(backend, trace=trace, warn=warn)
    summary = r.run(max_ticks=ticks)
    return r, backend, summary


def test_first_matching_rule_acts_and_commands_are_sent_on_change(write) -> None:
    body = ("stop: tick >= 5\nrules:\n  - if sonar5 <= 0.5 then arc(-2, 2)\n"
            "  - if sonar2 <= 0.5 then stop()\n  - else move(3)\n")
    #            tick:   0    1    2    3    4
    script = {"sonar5": [1.0, 0.4, 0.4, 1.0, 1.0],
              "sonar2": [1.0, 1.0, 0.1, 0.1, 1.0]}
    r, backend, summary = run(write, body, script)
    assert summary.ticks == 5
    # rule ids per tick: main:3, main:1, main:1, main:2, main:3; acts only when the command changes
    assert backend.acts == [(0, 0, 3.0, 3.0), (1, 0, -2.0, 2.0), (3, 0, 0.0, 0.0), (4, 0, 3.0, 3.0)]
    assert summary.rule_counts == {"main:1": 2, "main:2": 1, "main:3": 2}
    assert backend.tick == 5  # stepped once per acted tick; tick 5 stopped before acting


def test_goto_switches_state_from_the_next_tick(write) -> None:
    body = ("stop: tick >= 4\nrules:\n  wander:\n    - if sonar5 < 1 then goto follow, arc(1, 1)\n"
            "    - else move(5)\n  follow:\n    - if state == follow then move(2)\n")
    script = {"sonar5": [2.0, 0.5, 2.0, 2.0]}
    r, backend, summary = run(write, body, script)
    assert backend.acts == [(0, 0, 5.0, 5.0), (1, 0, 1.0, 1.0), (2, 0, 2.0, 2.0)]
    assert summary.rule_counts == {"wander:1": 1, "wander:2": 1, "follow:1": 2}


def test_stop_ends_the_run_before_acting(write) -> None:
    body = "stop: sonar5 < 1\nrules:\n  - always move(1)\n"
    r, backend, summary = run(write, body, {"sonar5": [5, 5, 0.5, 5]})
    assert summary.ticks == 2
    assert backend.tick == 2 and backend.acts == [(0, 0, 1.0, 1.0)]


def test_wheel_commands_are_clamped_and_counted(write) -> None:
    body = "stop: tick >= 3\nrules:\n  - if sonar5 < 1 then arc(50, -50)\n  - else move(1)\n"
    r, backend, summary = run(write, body, {"sonar5": [0.5, 0.5, 2]})
    assert backend.acts == [(0, 0, 12.3, -12.3), (2, 0, 1.0, 1.0)]
    assert summary.robots["p"].clamped_ticks == 2


def test_nan_command_stops_the_wheel_with_one_warning(write) -> None:
    body = ("stop: tick >= 4\nlet:\n  q: sonar5 / sonar2\nrules:\n  - always arc(q, 1)\n")
    warnings: list[str] = []
    r, backend, summary = run(write, body, {"sonar5": [0.0], "sonar2": [0.0]}, warn=warnings.append)
    # nan never equals the last command, so it is sent (as a stopped wheel) every tick it occurs
    assert backend.acts == [(t, 0, 0.0, 1.0) for t in range(4)]
    assert len(warnings) == 2  # 0/0 in the signal, then nan reaching the wheel; once each
    assert "division by zero in signal 'q', robot p, tick 0" in warnings[0]
    assert "nan wheel command (the wheel is stopped) in rule main:1, robot p, tick 0" in warnings[1]
    assert list(summary.faults) == [
        "signal 'q': division by zero: 5 times (first at tick 0, robot p)",  # tick 4 too: signals precede stop
        "rule main:1: nan wheel command (the wheel is stopped): 4 times (first at tick 0, robot p)"]


def test_metrics_fold_every_acted_tick(write) -> None:
    body = ("stop: tick >= 6\nrules:\n  - always stop()\nmetrics:\n"
            "  near: count(sonar5 < 1)\n  held: duration(sonar5 < 1)\n  mean5: mean(sonar5)\n"
            "  low: minimum(sonar5)\n  high: maximum(sonar5)\n  last: final(sonar5)\n")
    r, backend, summary = run(write, body, {"sonar5": [2, 0.5, 0.5, 2, 0.5, 4]})
    assert summary.robots["p"].metrics == {"near": 2, "held": 1.5, "mean5": 9.5 / 6, "low": 0.5,
                                              "high": 4, "last": 4}


def test_no_rule_holds_keeps_the_last_command(write) -> None:
    body = "stop: tick >= 3\nrules:\n  - if sonar5 < 1 then move(2)\n"
    r, backend, summary = run(write, body, {"sonar5": [0.5, 2, 2]})
    assert backend.acts == [(0, 0, 2.0, 2.0)]
    assert summary.idle_ticks == 2


def test_fleet_robots_have_their_own_state(write) -> None:
    text = ("stop: tick >= 3\nrobots:\n  p: {model: pioneer_p3dx, count: 2, at: spawn}\n"
            "let:\n  r: randint(0, 1000000)\nrules:\n  wait:\n    - if sonar5 < 1 then goto go\n    - else stop()\n"
            "  go:\n    - always arc(r, 1)\n")
    head = HEAD.replace("robots:\n  p: {model: pioneer_p3dx, at: [0, 0, 0]}\n", "")
    behaviour = compile_behaviour(write(head + text))
    # robot 0 sees a wall at tick 0, robot 1 never
    backend = FakeBackend(lambda tick, robot, ch: 0.5 if robot == 0 else 2.0)
    r = behaviour.bind(backend)
    summary = r.run()
    assert [x.name for x in r.robots] == ["p[0]", "p[1]"]
    assert [(t, i, left == right) for t, i, left, right in backend.acts] == [
        (0, 0, True), (0, 1, True), (1, 0, False), (2, 0, False)]
    assert summary.rule_counts == {"wait:1": 1, "wait:2": 3, "go:1": 2}


def test_trace_rows(write, tmp_path) -> None:
    body = ("stop: tick >= 3\nlet:\n  near: sonar5 < 1\nrules:\n  - if near then arc(-2, 2)\n  - else move(1)\n"
            "metrics:\n  hits: count(near)\n")
    path = tmp_path / "t.csv"
    run(write, body, {"sonar5": [2, 0.5, math.inf]}, trace=path)
    trace = read_trace(path)
    assert trace.header["format"] == 1 and trace.header["backend"] == "fake" and trace.header["seed"] == 3
    assert trace.columns == ["tick", "time", "robot", "x", "y", "heading", "collided", "state", "rule",
                             "sonar5", "near", "wheel_left", "wheel_right", "events"]
    assert trace.rows == [
        ["0", "0", "p", "0", "0", "0", "0", "main", "main:2", "2", "0", "1", "1", ""],
        ["1", "0.5", "p", "1", "0", "0", "0", "main", "main:1", "0.5", "1", "-2", "2", "hits"],
        ["2", "1", "p", "2", "0", "0", "0", "main", "main:2", "inf", "0", "1", "1", ""],
    ]


def test_interrupt_keeps_the_trace(write, tmp_path) -> None:
    calls = []

    def script(tick, robot, ch):
        calls.append(tick)
        if tick == 3:
            raise KeyboardInterrupt
        return 2.0
    path = tmp_path / "t.csv"
    r, backend, summary = run(write, "stop: tick >= 10 or sonar5 < 0\nrules:\n  - always move(1)\n", script,
                              trace=path)
    assert summary.interrupted and summary.ticks == 3
    assert [row[0] for row in read_trace(path).rows] == ["0", "1", "2"]


def test_stop_horizon_for_the_progress_bar(write) -> None:
    horizon = lambda stop: compile_behaviour(write(  # noqa: E731
        HEAD + f"params: {{minutes: 2}}\nstop: {stop}\nrules:\n  - always stop()\n")).program.stop_horizon_s
    assert horizon("time >= minutes * 60") == 120.0
    assert horizon("collided or tick >= 40") == 20.0
    assert horizon("collided") is None


def test_a_fault_names_the_agent_that_ran_into_it_not_a_slider(write) -> None:
    path = write("labsim: 1\nworld: crane\nstop: tick >= 2\nsliders:\n"
                 "  arm: {min: -10, max: 10, label: 'root: {sqrt(arm - 100):.2f}'}\n  crab: {min: -10, max: 10}\n"
                 "bind:\n  Arm_Actuator.velocity: 0.02 * arm\n")
    warnings: list[str] = []
    r = compile_behaviour(path).bind(load_backend("pymunk"), warn=warnings.append)
    summary = r.run()
    r.close()
    assert "sqrt(): math domain error in a label, robot crane, tick 0" in warnings[0]
    assert list(summary.faults) == ["a label: sqrt(): math domain error: 3 times (first at tick 0, robot crane)"]


def test_a_seed_given_to_the_runtime_gives_the_trace_of_that_seed_in_the_file(write, tmp_path) -> None:
    body = ("stop: tick >= 20\nrobots:\n  p: {model: pioneer_p3dx, at: random}\nlet:\n  r: randint(0, 100)\n"
            "rules:\n  - always arc(r - 1, r + 1)\n")
    files = {seed: write(f"labsim: 1\nworld: walls_lab4\nseed: {seed}\n{body}", f"seed{seed}.yaml") for seed in (1, 7)}

    def trace(file_seed: int, seed: int | None = None) -> tuple[object, list[list[str]]]:
        path = tmp_path / f"{file_seed}-{seed}.csv"
        r = compile_behaviour(files[file_seed], seed=seed).bind(load_backend("pymunk"), trace=path)
        r.run()
        r.close()
        t = read_trace(path)
        return t.header["seed"], t.rows

    assert trace(1, seed=7) == trace(7)
    assert trace(1) != trace(7)  # the seed decides the start pose and the random numbers
    assert main(["run", str(files[1]), "--seed", "7", "--trace", str(tmp_path / "cli.csv"), "-q"]) == 0
    assert read_trace(tmp_path / "cli.csv").rows == trace(7)[1]
