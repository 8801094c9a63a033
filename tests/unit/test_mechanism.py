"""Mechanisms: the world file's ``mechanism:`` section and the pymunk scene that runs it.

Most tests drive the tower-crane lab's world (backends/scene/worlds/crane.yaml): each joint under
velocity and position targets, its limits, the force sensor, the load's swing, the floor, and
determinism. A pendulum and a tilted rail check the joint kinds the crane does not use. The
last tests check that each mistake in a world file is reported at its line and column.
"""
from __future__ import annotations

import dataclasses
import itertools
import math
import statistics
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from labsim.backends.pymunk.mechanism import MechanismError, MechanismScene
from labsim.backends.scene.mechanism import BodySpec, JointSpec, Mechanism, MotorSpec
from labsim.backends.scene.mechanism_file import read_mechanism
from labsim.backends.scene.world import builtin_worlds
from labsim.backends.scene.world_file import load_world
from labsim.foundation.diagnostics import LabsimError, Report
from labsim.foundation.source import loads

G = 9.81
LOAD_KG = 200.0
CRAB, HOIST, SLEW, SENSOR = "Crab_Actuator", "Hoist_Actuator", "Arm_Actuator", "Force_sensor"


@pytest.fixture(scope="module")
def crane() -> Mechanism:
    report = Report()
    world = load_world(builtin_worlds()["crane"], report)
    assert report.diagnostics == []
    assert isinstance(world.mechanism, Mechanism)
    return world.mechanism


def run(scene: MechanismScene, seconds: float,
        watch: Callable[[MechanismScene], Any] | None = None) -> list[Any]:
    """Step for `seconds`; return watch(scene) after every tick."""
    out = []
    for _ in range(round(seconds / scene.dt_s)):
        scene.step()
        if watch is not None:
            out.append(watch(scene))
    return out


def lifted(crane: Mechanism, rope_m: float = 3.65) -> MechanismScene:
    """The crane with its load hoisted off the floor (1.5 m up by default) and at rest."""
    s = MechanismScene(crane, 0.05)
    s.set_target_position(HOIST, rope_m)
    run(s, 12.0)
    return s


# -- the crane as built -------------------------------------------------------------------------


def test_crane_world_builds_the_lab_model(crane: Mechanism) -> None:
    assert {j.name for j in crane.joints} >= {CRAB, HOIST, SLEW}
    assert crane.slew is not None and crane.slew.name == SLEW
    s = MechanismScene(crane)
    assert s.joint_position(CRAB) == pytest.approx(3.0)  # crab 3 m from the tower's axis
    assert s.joint_position(HOIST) == pytest.approx(5.15)  # guide's end z 6.95 to hook z 1.8
    assert s.body_pose("Tower") == pytest.approx((-2, 4.15, 0))
    assert s.body_pose("Load") == pytest.approx((1, 0.3, 0))
    assert s.body_pose("Upper_guide") == pytest.approx((1, 7.3, 0))
    run(s, 2.0)  # nothing commanded: everything stays where it is
    assert s.body_pose("Crab") == pytest.approx((1, 7.825, 0), abs=1e-6)
    assert s.body_pose("Load")[:2] == pytest.approx((1, 0.3), abs=1e-3)


# -- each joint under a velocity target -------------------------------------------------------


def test_crab_moves_at_the_commanded_velocity_along_the_arm(crane: Mechanism) -> None:
    s = lifted(crane)
    s.set_target_velocity(CRAB, 0.8)
    run(s, 2.0)  # 0.8 m/s at 0.5 m/s^2: up to speed after 1.6 s
    assert s.joint_velocity(CRAB) == pytest.approx(0.8, abs=1e-6)
    x0 = s.joint_position(CRAB)
    run(s, 1.5)
    assert s.joint_position(CRAB) - x0 == pytest.approx(1.2, abs=1e-4)
    x, z, angle = s.body_pose("Crab")
    assert x == pytest.approx(-2 + s.joint_position(CRAB), abs=1e-6)  # position is along the arm
    assert z == pytest.approx(7.825, abs=1e-4) and angle == pytest.approx(0, abs=1e-6)


def test_crab_velocity_is_clamped_to_its_max_speed(crane: Mechanism) -> None:
    slow = dataclasses.replace(crane, joints=tuple(
        dataclasses.replace(j, motor=dataclasses.replace(j.motor, max_speed=1.0))
        if j.name == CRAB and j.motor is not None else j for j in crane.joints))
    s = lifted(slow)
    s.set_target_position(CRAB, 1.0)
    run(s, 10.0)
    s.set_target_velocity(CRAB, 5.0)
    speeds = run(s, 4.0, lambda s: s.joint_velocity(CRAB))
    assert max(speeds) == pytest.approx(1.0, abs=1e-6)


def test_the_crane_s_motors_take_every_slider_step(crane: Mechanism) -> None:
    """The lab's sliders go to 10 and its script sets the joints' target velocities to their
    values: each step is a speed of its own, reached at max_accel (behaviours/crane.yaml)."""
    for name in (CRAB, HOIST, SLEW):
        motor = next(j.motor for j in crane.joints if j.name == name)
        assert motor is not None and motor.max_speed == 10 and motor.max_accel == 0.5
    finals = []
    for target in (0.4, 0.5, 0.6, 9.9, 10.0):  # slider steps of 0.1, below and above the old 0.5 cap
        s = lifted(crane)
        s.set_target_velocity(SLEW, target)
        run(s, 25.0)
        finals.append(s.joint_velocity(SLEW))
    assert finals == pytest.approx([0.4, 0.5, 0.6, 9.9, 10.0], abs=1e-9)


def test_hoist_rope_length_changes_at_the_commanded_velocity(crane: Mechanism) -> None:
    s = lifted(crane)
    s.set_target_velocity(HOIST, -0.4)  # negative: a shorter rope, the hook goes up
    run(s, 1.0)  # up to speed after 0.8 s
    assert s.joint_velocity(HOIST) == pytest.approx(-0.4)
    rope0, hook0 = s.joint_position(HOIST), s.body_pose("Gripper")[1]
    run(s, 2.0)
    assert s.joint_position(HOIST) - rope0 == pytest.approx(-0.8, abs=1e-9)
    assert s.body_pose("Gripper")[1] - hook0 == pytest.approx(0.8, abs=2e-3)  # the hook follows


def test_slew_angle_integrates_the_commanded_velocity(crane: Mechanism) -> None:
    s = lifted(crane)
    s.set_target_velocity(SLEW, 0.3)
    run(s, 1.0)  # 0.3 rad/s at 0.5 rad/s^2: up to speed after 0.6 s
    a0 = s.slew_angle
    run(s, 2.0)
    assert s.slew_angle - a0 == pytest.approx(0.6, abs=1e-9)
    assert s.joint_position(SLEW) == s.slew_angle and s.joint_velocity(SLEW) == pytest.approx(0.3)
    s.set_target_velocity(SLEW, 12.0)
    run(s, 3.0)
    assert s.joint_velocity(SLEW) == pytest.approx(0.3 + 0.5 * 3.0)  # ramping at its max accel
    run(s, 30.0)
    assert s.joint_velocity(SLEW) == pytest.approx(10.0)  # its max speed
    # The plane does not move in 2D; world_position turns it about the tower's axis (x = -2).
    x, z, _ = s.body_pose("Crab")
    assert (x, z) == pytest.approx((1, 7.825), abs=1e-3)
    a = s.slew_angle
    assert s.world_position("Crab") == pytest.approx((-2 + 3 * math.cos(a), 3 * math.sin(a), z), abs=1e-3)
    assert s.world_position("Tower") == pytest.approx((-2, 0, 4.15))  # on the axis


# -- limits -----------------------------------------------------------------------------------


def test_crab_stops_at_both_ends_of_its_rail(crane: Mechanism) -> None:
    s = lifted(crane)
    s.set_target_velocity(CRAB, 1.0)
    out = run(s, 12.0, lambda s: s.joint_position(CRAB))
    assert max(out) <= 7.2 + 1e-3
    assert s.joint_position(CRAB) == pytest.approx(7.2, abs=1e-3)  # the arm's tip
    assert s.body_pose("Crab")[0] + 0.55 / 2 <= 5.5 + 1e-3  # still on the arm
    s.set_target_velocity(CRAB, -1.0)
    out = run(s, 14.0, lambda s: s.joint_position(CRAB))
    assert min(out) >= 0.6 - 1e-3 and s.joint_position(CRAB) == pytest.approx(0.6, abs=1e-3)


def test_hoist_stops_at_its_limits(crane: Mechanism) -> None:
    s = lifted(crane)
    s.set_target_velocity(HOIST, -0.5)
    run(s, 10.0)
    assert s.joint_position(HOIST) == 0.3  # exactly: the winch is integrated
    s.set_target_velocity(HOIST, 0.5)
    run(s, 16.0)
    assert s.joint_position(HOIST) == 6.85


def test_slew_limits_hold() -> None:
    arm = Mechanism(
        (BodySpec("post", "box", (0, 1), (0.2, 2), static=True),
         BodySpec("jib", "box", (1, 2.1), (2, 0.2), static=True)),
        (JointSpec("turn", "slew", "post", "jib", (0, 2), limits=(-1.0, 1.5), motor=MotorSpec(1, 0.8)),),
    )
    s = MechanismScene(arm)
    s.set_target_velocity("turn", 0.8)
    run(s, 3.0)
    assert s.slew_angle == 1.5
    s.set_target_velocity("turn", -0.8)
    run(s, 5.0)
    assert s.slew_angle == -1.0


def test_hook_never_goes_through_the_floor(crane: Mechanism) -> None:
    """Lowering past the load's landing: the load stands on the floor, the rope goes slack."""
    s = MechanismScene(crane)
    s.set_target_velocity(HOIST, 0.5)
    low = run(s, 20.0, lambda s: (s.body_pose("Gripper")[1], s.body_pose("Load")[1], s.force(SENSOR)))
    assert s.joint_position(HOIST) == 6.85
    assert min(h for h, _, _ in low) >= 0.1 - 0.005  # the hook's centre, 0.1 above its bottom
    assert min(z for _, z, _ in low) >= 0.3 - 0.005  # the load's centre, 0.3 above its bottom
    assert s.force(SENSOR) == 0.0  # nothing hangs on the sling


def test_hook_never_goes_into_the_arm_even_while_swinging(crane: Mechanism) -> None:
    s = lifted(crane)
    s.set_target_velocity(CRAB, 1.0)
    s.set_target_velocity(HOIST, -0.5)

    def gap(s: MechanismScene) -> float:  # from the hook's top to the guide's lower end
        guide_bottom = s.body_pose("Upper_guide")[1] - 0.35
        return guide_bottom - (s.body_pose("Gripper")[1] + 0.1)

    gaps = run(s, 6.0, gap)
    s.set_target_velocity(CRAB, -1.0)  # reverse at full speed: the load swings hard
    gaps += run(s, 10.0, gap)
    assert s.joint_position(HOIST) == 0.3
    assert min(gaps) > 0.15
    assert max(s.body_pose("Gripper")[1], s.body_pose("Load")[1]) < 8.0  # below the arm


# -- position targets -------------------------------------------------------------------------


def test_crab_reaches_a_target_position_without_overshoot_and_holds_it(crane: Mechanism) -> None:
    s = lifted(crane)
    s.set_target_position(CRAB, 6.0)
    out = run(s, 8.0, lambda s: s.joint_position(CRAB))
    assert max(out) <= 6.0 + 0.003
    assert s.joint_position(CRAB) == pytest.approx(6.0, abs=1e-3)
    held = run(s, 20.0, lambda s: s.joint_position(CRAB))  # while the load swings
    assert max(abs(x - 6.0) for x in held) < 2e-3
    s.set_target_position(CRAB, 2.0)
    out = run(s, 10.0, lambda s: s.joint_position(CRAB))
    assert min(out) >= 2.0 - 0.003 and s.joint_position(CRAB) == pytest.approx(2.0, abs=1e-3)


def test_hoist_and_slew_reach_target_positions(crane: Mechanism) -> None:
    s = lifted(crane)
    s.set_target_position(HOIST, 1.0)
    s.set_target_position(SLEW, math.pi / 2)
    out = run(s, 10.0, lambda s: (s.joint_position(HOIST), s.slew_angle))
    assert min(h for h, _ in out) >= 1.0 - 1e-12 and s.joint_position(HOIST) == pytest.approx(1.0, abs=1e-9)
    assert max(a for _, a in out) <= math.pi / 2 + 1e-9
    assert s.slew_angle == pytest.approx(math.pi / 2, abs=1e-9)
    s.set_target_position(HOIST, 50.0)  # beyond the limit: goes to the limit
    run(s, 20.0)
    assert s.joint_position(HOIST) == 6.85


# -- the force sensor and the swing ----------------------------------------------------------


def test_force_sensor_reads_the_load_weight_at_rest(crane: Mechanism) -> None:
    s = lifted(crane)
    readings = run(s, 5.0, lambda s: s.force(SENSOR))
    weight = LOAD_KG * G
    assert max(abs(f / weight - 1) for f in readings) < 0.02
    assert statistics.mean(readings) == pytest.approx(weight, rel=1e-3)


def test_force_sensor_reads_more_than_the_weight_while_hoisting_up(crane: Mechanism) -> None:
    s = lifted(crane)
    weight = LOAD_KG * G
    s.set_target_velocity(HOIST, -0.5)  # up, ramping at 0.5 m/s^2 for 1 s
    ramp = run(s, 0.9, lambda s: s.force(SENSOR))
    assert min(ramp) > 1.03 * weight  # m (g + a) = 1.05 m g
    assert statistics.mean(ramp) == pytest.approx(LOAD_KG * (G + 0.5), rel=0.01)
    steady = run(s, 2.0, lambda s: s.force(SENSOR))[10:]  # at constant speed: the weight again
    assert statistics.mean(steady) == pytest.approx(weight, rel=0.01)


def test_load_swings_after_the_crab_stops_and_the_swing_decays(crane: Mechanism) -> None:
    s = lifted(crane)
    s.set_target_velocity(CRAB, 1.0)
    run(s, 3.0)
    s.set_target_velocity(CRAB, 0.0)
    run(s, 2.0)  # braking at 0.5 m/s^2

    def offset(s: MechanismScene) -> float:  # the load's horizontal offset from the crab
        return s.body_pose("Load")[0] - s.body_pose("Crab")[0]

    swing = run(s, 60.0, offset)
    assert abs(s.joint_velocity(CRAB)) < 1e-3  # the crab holds still while the load swings
    per = round(10.0 / s.dt_s)
    early = max(abs(x) for x in swing[:per])
    late = max(abs(x) for x in swing[-per:])
    assert early > 0.1  # a real swing, not a wobble
    # damping 0.1/s: the amplitude decays as exp(-0.05 t), so by about exp(-2.5) over 50 s
    assert late < 0.15 * early
    crossings = sum(1 for a, b in itertools.pairwise(swing) if a < 0 <= b)
    # a pendulum of about 6.5 m (rope, hook, sling, half the load) swings in about 5 s
    assert 10 <= crossings <= 14


# -- determinism and speed --------------------------------------------------------------------


def test_two_scenes_with_the_same_commands_read_the_same(crane: Mechanism) -> None:
    def session() -> list[Any]:
        s = MechanismScene(crane)
        out = []
        for t, (joint, v) in enumerate([(HOIST, -0.5), (CRAB, 1.0), (SLEW, 0.3), (CRAB, -0.7), (HOIST, 0.2)]):
            s.set_target_velocity(joint, v)
            out += run(s, 3.0 + t, lambda s: (s.joint_position(CRAB), s.joint_position(HOIST), s.slew_angle,
                                              s.force(SENSOR), s.body_pose("Load"), s.world_position("Gripper")))
        return out

    assert session() == session()


def pendulum(tilt_rad: float = 0.0, limits: tuple[float, float] | None = None,
             motor: MotorSpec | None = None) -> Mechanism:
    """A 1 kg bob 1 m below a pivot at the origin, started tilt_rad counter-clockwise."""
    c, s = math.cos(tilt_rad), math.sin(tilt_rad)
    return Mechanism(
        (BodySpec("frame", "box", (0, 0.05), (0.5, 0.1), static=True),
         BodySpec("bob", "box", (s, -c), (0.1, 0.1), mass_kg=1.0, angle_rad=tilt_rad)),
        (JointSpec("swing", "revolute", "frame", "bob", (0, 0), limits=limits, motor=motor),),
        floor_z_m=None,
    )


def test_free_pendulum_swings_with_its_period() -> None:
    tilt = math.radians(5)
    s = MechanismScene(pendulum(tilt), 0.01)
    assert s.body_pose("bob")[2] == pytest.approx(tilt)
    # the joint reads 0 at the start, so it swings between 0 and -2 * tilt
    angles = run(s, 20.0, lambda s: s.joint_position("swing") + tilt)
    assert min(angles) == pytest.approx(-tilt, rel=1e-2) and max(angles) == pytest.approx(tilt, rel=1e-2)
    ups = [i for i, (a, b) in enumerate(itertools.pairwise(angles)) if a < 0 <= b]
    period = (ups[-1] - ups[0]) * s.dt_s / (len(ups) - 1)
    moment = 1.0 * (0.1 ** 2 + 0.1 ** 2) / 12 + 1.0 * 1.0 ** 2  # about the pivot
    assert period == pytest.approx(2 * math.pi * math.sqrt(moment / (1.0 * G * 1.0)), rel=2e-3)


def test_motorised_revolute_joint_turns_to_velocity_and_position_targets() -> None:
    s = MechanismScene(pendulum(limits=(-1.0, 2.0), motor=MotorSpec(50.0, 1.5, 3.0)))  # N m, rad/s, rad/s^2
    s.set_target_velocity("swing", 1.0)
    run(s, 1.0)
    assert s.joint_velocity("swing") == pytest.approx(1.0, abs=1e-3)
    run(s, 3.0)
    assert s.joint_position("swing") == pytest.approx(2.0, abs=2e-3)  # held at its limit
    s.set_target_position("swing", -0.5)
    out = run(s, 4.0, lambda s: s.joint_position("swing"))
    assert min(out) > -0.5 - 0.005 and s.joint_position("swing") == pytest.approx(-0.5, abs=2e-3)


def test_passive_slider_on_a_tilted_rail_accelerates_with_g_sin_slope() -> None:
    rail = Mechanism(
        (BodySpec("rail", "box", (0, 0), (4, 0.05), static=True, angle_rad=math.radians(30)),
         BodySpec("slider", "box", (0, 0.1), (0.2, 0.1), mass_kg=2.0)),
        (JointSpec("slide", "prismatic", "rail", "slider", (0, 0.1),
                   axis=(math.cos(math.radians(30)), math.sin(math.radians(30))), limits=(-1.5, 1.5)),),
        floor_z_m=None,
    )
    s = MechanismScene(rail, 0.01)
    run(s, 0.5)
    # pymunk moves a body before it updates its velocity: after n sub-steps of h it has gone
    # a h^2 n (n - 1) / 2, which is a t^2 / 2 less one sub-step's worth (0.2 % here).
    n, h = 500, 0.001
    assert s.joint_position("slide") == pytest.approx(-G * 0.5 * h * h * n * (n - 1) / 2, rel=1e-6)
    run(s, 2.0)
    assert s.joint_position("slide") == pytest.approx(-1.5, abs=1e-3)  # at its lower stop
    assert s.body_pose("slider")[2] == pytest.approx(0, abs=1e-6)  # a rail does not let it turn


# -- programming mistakes name the joint ------------------------------------------------------


def test_scene_errors_name_the_joint(crane: Mechanism) -> None:
    s = MechanismScene(crane)
    with pytest.raises(MechanismError, match=r"no joint 'Crab_actuator' \(did you mean 'Crab_Actuator'\?\)"):
        s.set_target_velocity("Crab_actuator", 1.0)
    with pytest.raises(MechanismError, match="joint 'guide_mount' has no motor"):
        s.set_target_position("guide_mount", 1.0)
    with pytest.raises(MechanismError, match="no force sensor 'Force'"):
        s.force("Force")
    with pytest.raises(MechanismError, match=r"no body 'Lod'.*'Load'"):
        s.body_pose("Lod")
    only_position = dataclasses.replace(crane.joint(CRAB), motor=MotorSpec(2000, 1.0, velocity=False))
    m = dataclasses.replace(crane, joints=tuple(only_position if j.name == CRAB else j for j in crane.joints))
    with pytest.raises(MechanismError, match="joint 'Crab_Actuator' takes position targets only"):
        MechanismScene(m).set_target_velocity(CRAB, 1.0)
    moving_parent = dataclasses.replace(
        crane,
        joints=crane.joints + (JointSpec("extra", "prismatic", "Crab", "Load", (1, 0.3), motor=MotorSpec(1, 1)),))
    with pytest.raises(MechanismError, match="joint 'extra': a motorised prismatic joint needs a static parent"):
        MechanismScene(moving_parent)


# -- world files ------------------------------------------------------------------------------

WORLD = """\
labsim-world: 1
name: bad
mechanism:
  gravity: 9.81
  dampnig: 0.1
  bodies:
    post: {shape: box, center: [0, 1], size: [0.2, 2], static: true}
    cart: {shape: box, center: [1, 2], size: [0.4, 0], mass: 5}
    bob: {shape: sphere, center: [1, 0.5], size: [0.2, 0.2], mass: -1}
    weight: {shape: box, center: [2, 0.5], size: [0.2, 0.2]}
    ok: {shape: cylinder, center: [3, 0.5], size: [0.2, 0.2], mass: 1}
  joints:
    rail: {kind: prismatic, parent: post, child: cartt, anchor: [0, 2], axis: [1, 0]}
    hinge: {kind: revolute, parent: post, child: ok, anchor: [3, 1], limits: [1, -1]}
    winch: {kind: prismatic, rope: true, parent: post, child: ok, anchor: [3, 2], limit: [0, 2]}
    spin: {kind: rotary, parent: post, child: ok, anchor: [0, 0]}
    drive:
      kind: prismatic
      parent: post
      child: bob
      anchor: [0, 0.5]
      axis: [1, 0]
      motor: {max_force: 1e5, max_speed: 0, targets: [velocity, positon]}
  force_sensors:
    hinge: {between: [post, ok]}
"""


def diagnostics(text: str, write: Callable[..., Path]) -> set[tuple[int, int, str]]:
    report = Report()
    assert load_world(write(text, "bad.yaml"), report) is None
    return {(d.line, d.col, d.message) for d in report.diagnostics}


def test_world_file_mistakes_are_reported_at_their_line_and_column(write: Callable[..., Path]) -> None:
    assert diagnostics(WORLD, write) == {
        (5, 3, "unknown key 'dampnig' in mechanism (did you mean 'damping'?)"),
        (8, 46, "a body's size must be positive"),
        (9, 18, "unknown shape 'sphere': box or cylinder"),
        (9, 68, "mass (kg) must be positive"),
        (10, 13, "body 'weight' moves, so it needs 'mass' (kg) or 'density' (kg/m^3); or say 'static: true'"),
        (13, 50, "unknown body 'cartt' (did you mean 'cart'?)"),
        (14, 78, "limits are [lo, hi] with lo < hi (got [1, -1])"),
        (15, 83, "unknown key 'limit' in joint 'winch' (did you mean 'limits'?)"),
        (16, 18, "unknown joint kind 'rotary': revolute, prismatic, slew, fixed"),
        (23, 42, "max_speed (m/s) must be positive"),
        (23, 65, "unknown target 'positon': velocity or position (did you mean 'position'?)"),
        (25, 5, "duplicate name 'hinge' (a joint or force sensor on line 14)"),
    }


def test_limits_and_structure_mistakes(write: Callable[..., Path]) -> None:
    text = """\
labsim-world: 1
mechanism:
  bodies:
    arm: {center: [0, 2], size: [4, 0.2], static: true}
    cart: {center: [1, 1.8], size: [0.4, 0.2], mass: 5}
    weight: {center: [1, 1], size: [0.2, 0.2], mass: 1}
    bob: {center: [2, 1], size: [0.2, 0.2], mass: 1}
  joints:
    rail: {kind: prismatic, parent: arm, child: cart, anchor: [0, 1.8], axis: [1, 0], limits: [2, 3]}
    slide: {kind: prismatic, parent: arm, child: weight, anchor: [0, 1], axis: [1, 0]}
    again: {kind: revolute, parent: arm, child: weight, anchor: [0, 1]}
    self: {kind: fixed, parent: arm, child: arm}
    turn: {kind: revolute, parent: weight, child: arm, anchor: [0, 0], limits_deg: [-90, 90]}
    wheel: {kind: revolute, parent: cart, child: bob, anchor: [2, 1.5], limits_deg: [10, 90]}
    tilt: {kind: prismatic, parent: arm, child: bob, anchor: [2, 1], axis: [0, 0], limits_deg: [0, 1]}
"""
    assert diagnostics(text, write) == {
        (9, 95, "'cart' starts at 1 m along 'rail', outside its limits [2, 3]"),
        (11, 5, "body 'weight' is already the child of joint 'slide'; a body has one parent joint"),
        (12, 45, "joint 'self' joins 'arm' to itself"),
        (13, 51, "'arm' is static: a revolute joint's child must be able to move"),
        (14, 85, "'wheel' starts at angle 0, so its limits must include 0"),
        (15, 76, "the axis must not be [0, 0]"),
        (15, 96, "'limits_deg' is for revolute and slew joints; a prismatic joint's limits are in metres"),
    }


def test_welded_bodies_cannot_be_jointed(write: Callable[..., Path]) -> None:
    text = """\
labsim-world: 1
mechanism:
  bodies:
    ground: {center: [0, 0], size: [4, 0.2], static: true}
    post: {center: [0, 1], size: [0.2, 2], mass: 3}
    arm: {center: [1, 2], size: [2, 0.2], mass: 1}
  joints:
    weld: {kind: fixed, parent: post, child: arm}
    hinge: {kind: revolute, parent: arm, child: post, anchor: [0, 2]}
"""
    assert diagnostics(text, write) == {
        (9, 5, "joint 'hinge' joins 'arm' and 'post', which fixed or slew joints already weld together"),
    }


def test_a_body_welded_to_a_static_body_cannot_be_a_joints_child(write: Callable[..., Path]) -> None:
    text = """\
labsim-world: 1
mechanism:
  bodies:
    ground: {center: [0, 0], size: [4, 0.2], static: true}
    post: {center: [0, 1], size: [0.2, 2], mass: 3}
    arm: {center: [1, 2], size: [2, 0.2], mass: 1}
  joints:
    weld: {kind: fixed, parent: ground, child: post}
    hinge: {kind: revolute, parent: arm, child: post, anchor: [0, 2]}
"""
    assert diagnostics(text, write) == {
        (9, 5, "body 'post' is already the child of joint 'weld'; a body has one parent joint"),
    }
    text = text.replace("weld: {kind: fixed, parent: ground, child: post}",
                        "weld: {kind: fixed, parent: post, child: ground}")
    assert diagnostics(text, write) == {
        (9, 5, "joint 'hinge': 'post' is welded to a static body, so it cannot move"),
    }


def test_duplicate_body_names_are_refused_by_the_loader() -> None:
    with pytest.raises(LabsimError) as e:
        loads("mechanism:\n  bodies:\n    a: {center: [0, 0], size: [1, 1], static: true}\n"
              "    a: {center: [0, 0], size: [1, 1], static: true}\n")
    d = e.value.diagnostics[0]
    assert (d.line, d.col, d.message) == (4, 5, "duplicate key 'a' (first given on line 3)")


def test_read_mechanism_on_a_node_and_numbers_with_exponents() -> None:
    # YAML 1.1 would read 1e3 as text; labsim's loader reads it as YAML 1.2 does
    doc = loads("mechanism:\n  gravity: 1e3\n  bodies:\n    a: {center: [0, 0], size: [1, 1], static: true}\n")
    report = Report()
    m = read_mechanism(doc.root.value[0][1], doc, report)
    assert m is not None and m.gravity_m_s2 == 1000.0 and report.diagnostics == []
    doc = loads("mechanism:\n  floor: null\n  bodies:\n    a: {center: [0, 0], size: [1, 1], static: true}\n")
    m = read_mechanism(doc.root.value[0][1], doc, Report())
    assert m is not None and m.floor_z_m is None and m.gravity_m_s2 == 9.81 and m.bodies[0].shape == "box"


def test_crane_world_file_says_it_is_2d() -> None:
    head = Path(builtin_worlds()["crane"]).read_text().split("labsim-world")[0]
    assert "2D" in head and "slew" in head.lower() and "NOT simulated" in head
