"""The lidar's fan cast (backends/pymunk/lidar_fan.py) against chipmunk's own ray casts.

Random worlds of round-ended walls, boxes (some with rounded corners), discs and other robots,
the lidar at random poses among them: every beam reads what casting it through chipmunk reads,
to 1e-12 m but for beams that graze a round end (measured: one beam in 80,000, 3e-12 m). Both
fans are tried, the C kernel (backends/pymunk/_fan.c) and numpy's, and against each other;
without the kernel built its tests skip, saying how to build it, but under CI (``CI=true``,
where the install has a C compiler) they fail.
"""
from __future__ import annotations

import math
import random

import pymunk
import pytest
from random_worlds import FOOTPRINT, kernel_built, random_world

from labsim.backends.pymunk import lidar_fan
from labsim.backends.pymunk.lidar_fan import LidarFan


@pytest.fixture(params=[True, False], ids=["C kernel", "numpy"])
def compiled(request: pytest.FixtureRequest) -> bool:
    """Which fan a test casts with: the C kernel (where built) and numpy's."""
    if request.param:
        kernel_built(lidar_fan.KERNEL)
    return bool(request.param)



def _differences(seed: int, compiled: bool, against_numpy: bool = False) -> list[float]:
    """|fan - chipmunk| of every beam over five poses of one random world; inf for a beam one
    reads as a hit and the other as a miss. With ``against_numpy``, |fan - numpy's fan|."""
    rng = random.Random(seed)
    space, bodies = random_world(rng, 5, 4, 2)
    me = bodies[0]
    beams = rng.choice([1, 7, 90, 360])
    angles = [rng.uniform(-math.pi, math.pi) for _ in range(beams)]
    mount_m, range_m = rng.choice([0.0, 0.1]), rng.uniform(0.5, 12)
    fan = LidarFan(space, me, pymunk.ShapeFilter(group=1), angles, mount_m, range_m, compiled=compiled)
    numpy_fan = LidarFan(space, me, pymunk.ShapeFilter(group=1), angles, mount_m, range_m, compiled=False)
    out = []
    for _ in range(5):
        me.position += (rng.uniform(-0.4, 0.4), rng.uniform(-0.4, 0.4))
        me.angle += rng.uniform(-1, 1)
        for other in bodies[1:]:
            other.position += (rng.uniform(-0.3, 0.3), 0.0)
            other.angle += 0.3
        for body in bodies:
            space.reindex_shapes_for_body(body)
        got = fan.cast(me.position.x, me.position.y, me.angle)
        want = (numpy_fan.cast if against_numpy else fan.cast_through_chipmunk)(me.position.x, me.position.y,
                                                                               me.angle)
        out += [0.0 if g == w else abs(g - w) for g, w in zip(got, want)]
    return out


def test_the_fan_reads_what_chipmunk_casts_read_on_random_worlds(compiled: bool) -> None:
    differences = [d for seed in range(60) for d in _differences(seed, compiled)]
    assert len(differences) > 30_000
    assert max(differences) < 1e-10  # never a hit for a miss (inf), nor a different shape
    within = sum(d <= 1e-12 for d in differences)
    assert within >= len(differences) - 3, sorted(differences)[-5:]


def test_the_kernel_reads_what_the_numpy_fan_reads_on_random_worlds() -> None:
    kernel_built(lidar_fan.KERNEL)
    differences = [d for seed in range(60) for d in _differences(seed, True, against_numpy=True)]
    assert len(differences) > 30_000
    assert max(differences) <= 1e-12, sorted(differences)[-5:]


def _room_with_inner_wall() -> tuple[pymunk.Space, pymunk.Body]:
    space = pymunk.Space()
    for a, b in [((-5, -5), (5, -5)), ((5, -5), (5, 5)), ((5, 5), (-5, 5)), ((-5, 5), (-5, -5)), ((-5, 1), (0, 1))]:
        space.add(pymunk.Segment(space.static_body, a, b, 0.05))
    body = pymunk.Body(1, 1)
    shape = pymunk.Poly(body, FOOTPRINT)
    shape.filter = pymunk.ShapeFilter(group=1)
    space.add(body, shape)
    return space, body


@pytest.mark.parametrize(("x", "y"), [
    (2.0, 1.02),   # in the inner wall's band beyond its free end: chipmunk's reading, by chipmunk
    (0.02, 1.0),   # just off its round end, on its line
    (0.0, 1.0),    # inside the wall: every beam reads 0
    (2.0, -2.0),   # in the open
])
def test_the_fan_reads_what_chipmunk_reads_near_a_wall_end(x: float, y: float, compiled: bool) -> None:
    space, body = _room_with_inner_wall()
    body.position, body.angle = (x, y), 0.3
    space.reindex_shapes_for_body(body)
    angles = [math.radians(-180 + k) for k in range(360)]
    fan = LidarFan(space, body, pymunk.ShapeFilter(group=1), angles, 0.0, 8.0, compiled=compiled)
    got, want = fan.cast(x, y, 0.3), fan.cast_through_chipmunk(x, y, 0.3)
    assert got == pytest.approx(want, abs=1e-12, rel=0)
    if (x, y) == (0.0, 1.0):
        assert got == [0.0] * 360


def test_the_fan_is_deterministic_across_instances(compiled: bool) -> None:
    space, body = _room_with_inner_wall()
    angles = [math.radians(-180 + k) for k in range(360)]
    first = LidarFan(space, body, pymunk.ShapeFilter(group=1), angles, 0.1, 5.0, compiled=compiled)
    second = LidarFan(space, body, pymunk.ShapeFilter(group=1), angles, 0.1, 5.0, compiled=compiled)
    poses = [(-3.0 + 0.37 * k, -2.0 + 0.21 * k, 0.4 * k) for k in range(20)]
    assert [first.cast(*p) for p in poses] == [second.cast(*p) for p in reversed(poses)][::-1]


@pytest.mark.parametrize("x", [0.06, 0.2, 1.0, 3.0, 4.9])
@pytest.mark.parametrize("dy", [-0.049, 0.0, 0.03])
def test_in_a_walls_band_the_beams_that_can_meet_it_read_what_chipmunk_reads(x: float, dy: float,
                                                                            compiled: bool) -> None:
    """Along the inner wall's band beyond its free end, near it and far, at several headings:
    the beams cast through chipmunk are enough for every beam to read chipmunk's range."""
    space, body = _room_with_inner_wall()
    angles = [math.radians(-180 + k) for k in range(360)]
    fan = LidarFan(space, body, pymunk.ShapeFilter(group=1), angles, 0.0, 8.0, compiled=compiled)
    for heading in (0.0, 0.3, 2.0, -2.9):
        body.position, body.angle = (x, 1.0 + dy), heading
        space.reindex_shapes_for_body(body)
        got, want = fan.cast(x, 1.0 + dy, heading), fan.cast_through_chipmunk(x, 1.0 + dy, heading)
        assert got == pytest.approx(want, abs=1e-12, rel=0)
