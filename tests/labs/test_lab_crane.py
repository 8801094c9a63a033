"""The crane lab: sliders bound to joints, a timeline, labels, limits, swing and weight."""
from __future__ import annotations

from pathlib import Path

import pytest
from helpers import BEHAVIOURS

from labsim.backends import load_backend
from labsim.runtime.cli.main import main
from labsim.runtime.run import compile_behaviour
from labsim.runtime.trace import read_trace

LAB = BEHAVIOURS / "crane.yaml"
WEIGHT_N = 200 * 9.81  # the load's mass in backends/scene/worlds/crane.yaml


@pytest.fixture(scope="module")
def lab(tmp_path_factory):
    path = tmp_path_factory.mktemp("crane") / "crane.csv"
    behaviour = compile_behaviour(LAB)
    run = behaviour.bind(load_backend("pymunk"), trace=path, warn=lambda m: None)
    summary = run.run()
    run.close()
    return summary, read_trace(path)


def column(trace, name: str) -> list[float]:
    return [float(v) for v in trace.column(name)]


def test_the_load_is_lifted_moved_lowered_and_raised(lab) -> None:
    summary, trace = lab
    assert summary.ticks == 1200 and summary.faults == ()
    m = summary.robots["crane"].metrics
    assert 2.5 < m["highest_load"] < 3.0  # lifted about 2.4 m
    assert m["final_slew"] == pytest.approx(0.1 * 8, abs=1e-9)  # arm = 0.1 -> 0.1 rad/s for 8 s
    x = column(trace, "crab_x")
    assert max(x) == pytest.approx(1 + 3.6, abs=0.05)  # out at 0.6 m/s for 6 s, then back
    assert x[-1] == pytest.approx(1.0, abs=0.05)


def test_limits_hold(lab) -> None:
    _, trace = lab
    along = [x + 2 for x in column(trace, "crab_x")]  # from the tower's axis
    assert min(along) >= 0.6 - 1e-6 and max(along) <= 7.2 + 1e-6  # the crab stays on the arm
    rope = column(trace, "rope")
    assert min(rope) >= 0.3 - 1e-3 and max(rope) <= 6.85 + 1e-3  # hook below the guide, above the floor
    assert min(column(trace, "load_z")) >= 0.3 - 0.01  # the load's centre never below half its height


def test_the_load_swings_and_settles(lab) -> None:
    summary, trace = lab
    m = summary.robots["crane"].metrics
    assert m["max_swing"] > 0.3  # the crab stopped at 14 s with the load behind it
    assert m["final_swing"] < 0.15
    swing = column(trace, "swing")
    t = column(trace, "time")
    late = [abs(s) for s, tt in zip(swing, t) if tt > 55]
    early = [abs(s) for s, tt in zip(swing, t) if 44 < tt < 49]
    assert max(late) < max(early)  # damped


def test_the_force_sensor_reads_the_weight_at_rest_and_more_while_lifting(lab) -> None:
    summary, trace = lab
    assert summary.robots["crane"].metrics["final_tension"] == pytest.approx(WEIGHT_N, rel=0.02)
    tension = column(trace, "tension")
    t = column(trace, "time")
    lifting = [f for f, tt in zip(tension, t) if 40.5 < tt < 41.5]  # the hoist accelerating upwards
    assert max(lifting) > WEIGHT_N * 1.02


def test_timeline_events_land_on_their_tick_and_are_traced(lab) -> None:
    _, trace = lab
    events = {int(row[0]): row[-1] for row in trace.rows if row[-1]}
    assert events[0] == "hoist=-0.4"
    assert events[120] == "hoist=0;arm=0.1"
    assert events[160] == "crab=0.6"
    assert events[280] == "crab=0;arm=0"
    assert len(events) == 10
    arm = column(trace, "arm")
    assert arm[119] == 0 and arm[120] == 0.1  # the slider moves on the event's tick


def test_labels_in_the_trace_and_the_summary(lab) -> None:
    summary, trace = lab
    # one label, as the lab's script has it: the slider moved last writes 0.02 x its value
    assert "label:arm" not in trace.columns
    labels = trace.column("label:speed")
    assert labels[0] == "Hoist Speed: -0.01"  # hoist = -0.4 on the first tick
    assert labels[160] == "Crab Speed: 0.01" and labels[600] == "Crab Speed: -0.01"
    assert summary.robots["crane"].labels == {"speed": "Hoist Speed: 0.00"}


def test_the_lab_sets_each_joint_to_its_slider() -> None:
    text = LAB.read_text()
    for joint, slider in (("Arm", "arm"), ("Crab", "crab"), ("Hoist", "hoist")):
        assert f"{joint}_Actuator.velocity: {slider} " in text  # the script's setJointTargetVelocity(j, value)
        assert f'"{joint} Speed: {{0.02 * {slider}:.2f}}", label_name: speed' in text


@pytest.mark.slow
def test_same_timeline_same_trace(tmp_path: Path) -> None:
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    for p in (a, b):
        assert main(["run", str(LAB), "-q", "--trace", str(p)]) == 0
    assert a.read_bytes() == b.read_bytes()


def test_a_live_slider_move_is_an_event_like_the_timeline(tmp_path: Path) -> None:
    behaviour = compile_behaviour(LAB)
    run = behaviour.bind(load_backend("pymunk"), trace=tmp_path / "t.csv", warn=lambda m: None)
    for _ in range(10):  # a live view ticks the run itself and moves sliders between ticks
        run.tick()
    run.set_slider("crab", 99)  # clamped to the slider's range
    run.tick()
    run.close()
    trace = read_trace(tmp_path / "t.csv")
    assert trace.rows[10][-1] == "crab=10"
    assert trace.column("label:speed")[9:11] == ["Hoist Speed: -0.01", "Crab Speed: 0.20"]  # the shared label follows


def test_the_golden_trace_holds(capsys) -> None:
    assert main(["test", str(LAB)]) == 0
    assert "1 passed, 0 failed" in capsys.readouterr().out


def test_a_trace_replays_its_slider_moves(lab, tmp_path: Path) -> None:
    from labsim.runtime.trace import slider_events
    _, trace = lab
    moves = slider_events(trace)
    assert moves[160] == [("crab", 0.6)]
    # replayed into a behaviour without a timeline, the run is the same run
    text = LAB.read_text()
    no_timeline = tmp_path / "crane.yaml"
    no_timeline.write_text(text[:text.index("timeline:")] + text[text.index("let:"):])
    path = tmp_path / "replayed.csv"
    run = compile_behaviour(no_timeline).bind(load_backend("pymunk"), trace=path, replay=moves,
                                              warn=lambda m: None)
    run.run()
    run.close()
    assert read_trace(path).rows == trace.rows


def test_set_position_from_a_rule_reaches_its_target(write) -> None:
    path = write("labsim: 1\nworld: crane\nstop: time >= 12\nlet:\n  crab: Crab_Actuator.position\n"
                 "rules:\n  - if time < 1 then set_position(Crab_Actuator, 5.0)\n"
                 "  - else set_velocity(Hoist_Actuator, 0)\n"
                 "metrics:\n  where: final(crab)\n")
    run = compile_behaviour(path).bind(load_backend("pymunk"))
    summary = run.run()
    run.close()
    assert summary.robots["crane"].metrics["where"] == pytest.approx(5.0, abs=0.005)
