"""The ray caster (backends/pymunk/ray_cast.py) against chipmunk's own ray casts, both ways.

Random worlds of round-ended walls, boxes (some with rounded corners), discs and other robots,
a robot at random poses among them (sometimes inside a shape) with random sonars: lone rays
(IR sensors) and cones, with and without an incidence limit. Every reading is, bit for bit,
what casting each ray through pymunk's public ``segment_query_first`` reads, with the C kernel
(backends/pymunk/_fan.c, ``rays``) and with the Python rays, and the two are equal. Without the
kernel built its tests skip, saying how to build it; under CI (``CI=true``, where the install
has a C compiler) they fail.
"""
from __future__ import annotations

import dataclasses
import gc
import math
import random
from pathlib import Path
from typing import cast

import pymunk
import pytest
from helpers import BEHAVIOURS
from random_worlds import kernel_built, random_world

from labsim.backends import load_backend
from labsim.backends.protocol import RobotRequest
from labsim.backends.pymunk import ray_cast
from labsim.backends.pymunk.lidar_fan import LidarFan
from labsim.backends.pymunk.ray_cast import RaySet, SonarRay
from labsim.backends.scene.models import PIONEER_P3DX, Lidar
from labsim.backends.scene.world import Pose, Wall, World
from labsim.runtime.run import compile_behaviour


@pytest.fixture(params=[True, False], ids=["C kernel", "Python rays"])
def compiled(request: pytest.FixtureRequest) -> bool:
    """Which caster a test casts with: the C kernel (where built) and the Python rays."""
    if request.param:
        kernel_built(ray_cast.KERNEL)
    return bool(request.param)


def _rays(rng: random.Random) -> list[SonarRay]:
    """Random sonars and IR sensors on the robot: lone rays and cones of 2 to 7 rays."""
    out = []
    for _ in range(rng.randint(1, 16)):
        mx, my = rng.uniform(-0.2, 0.3), rng.uniform(-0.15, 0.15)
        axis, reach = rng.uniform(-math.pi, math.pi), rng.uniform(0.1, 4.0)
        ex, ey = reach * math.cos(axis), reach * math.sin(axis)
        if rng.random() < 0.3:
            out.append(SonarRay(mx, my, ex, ey, reach))
            continue
        half, n = rng.uniform(0.05, 0.6), rng.randint(2, 7)
        fan = tuple((reach * math.cos(axis - half + 2 * half * i / (n - 1)),
                     reach * math.sin(axis - half + 2 * half * i / (n - 1))) for i in range(n))
        out.append(SonarRay(mx, my, ex, ey, reach, fan, rng.choice([None, math.cos(math.radians(45)), 0.2])))
    return out


def _oracle(space: pymunk.Space, body: pymunk.Body, rays: list[SonarRay]) -> list[float]:
    """Every ray of every sonar through pymunk's own query, as sense() reads them."""
    (x, y), a = body.position, body.angle
    c, s = math.cos(a), math.sin(a)
    f = pymunk.ShapeFilter(group=1)
    out = []
    for ray in rays:
        ox, oy = x + c * ray.mount_x_m - s * ray.mount_y_m, y + s * ray.mount_x_m + c * ray.mount_y_m
        if not ray.fan:
            ex, ey = ray.end_dx_m, ray.end_dy_m
            hit = space.segment_query_first((ox, oy), (ox + c * ex - s * ey, oy + s * ex + c * ey), 0.0, f)
            out.append(math.inf if hit is None else hit.alpha * ray.range_m)
            continue
        nearest = math.inf
        for ex, ey in ray.fan:
            wx, wy = c * ex - s * ey, s * ex + c * ey
            hit = space.segment_query_first((ox, oy), (ox + wx, oy + wy), 0.0, f)
            if hit is not None and (ray.incidence_cos is None
                                    or hit.normal.x * wx + hit.normal.y * wy <= -ray.incidence_cos * ray.range_m):
                nearest = min(nearest, hit.alpha * ray.range_m)
        out.append(nearest)
    return out


def _readings(seed: int, compiled: bool) -> tuple[list[list[float]], list[list[float]], list[list[float]]]:
    """Ten poses of one random world: the caster's readings, the Python rays', chipmunk's."""
    rng = random.Random(seed)
    space, bodies = random_world(rng, 3, 3, 1)
    me, rays = bodies[0], _rays(rng)
    caster = RaySet(space, pymunk.ShapeFilter(group=1), rays, compiled=compiled)
    python = RaySet(space, pymunk.ShapeFilter(group=1), rays, compiled=False)
    got, by_python, want = [], [], []
    for _ in range(10):
        me.position += (rng.uniform(-0.6, 0.6), rng.uniform(-0.6, 0.6))
        me.angle += rng.uniform(-1, 1)
        for other in bodies[1:]:
            other.position += (rng.uniform(-0.3, 0.3), 0.0)
            other.angle += 0.3
        for body in bodies:
            space.reindex_shapes_for_body(body)
        (x, y), a = me.position, me.angle
        got.append(caster.cast(x, y, math.cos(a), math.sin(a)))
        by_python.append(python.cast(x, y, math.cos(a), math.sin(a)))
        want.append(_oracle(space, me, rays))
    return got, by_python, want


def test_the_caster_reads_what_chipmunks_casts_read_bit_for_bit(compiled: bool) -> None:
    readings = hits = 0
    for seed in range(150):
        got, _, want = _readings(seed, compiled)
        assert got == want, seed
        readings += sum(map(len, want))
        hits += sum(math.isfinite(v) for row in want for v in row)
    assert readings > 8_000
    assert 0.2 < hits / readings < 0.9  # both hits and misses are tried


def test_the_kernel_reads_what_the_python_rays_read() -> None:
    kernel_built(ray_cast.KERNEL)
    for seed in range(150, 250):
        got, by_python, _ = _readings(seed, True)
        assert got == by_python, seed


def test_a_robot_inside_a_wall_reads_zero_and_a_removed_block_is_seen_gone(compiled: bool) -> None:
    """A mount inside a shape: every lone ray and unlimited cone reads 0, as chipmunk's cast
    does; a shape removed (a block dragged away in a live view) is no longer seen."""
    space = pymunk.Space()
    wall = pymunk.Segment(space.static_body, (-1.0, 0.0), (1.0, 0.0), 0.2)
    space.add(wall)
    rays = [SonarRay(0.0, 0.0, 1.0, 0.0, 1.0),
            SonarRay(0.0, 0.0, 1.0, 0.0, 1.0, ((1.0, -0.1), (1.0, 0.0), (1.0, 0.1)))]
    caster = RaySet(space, pymunk.ShapeFilter(group=1), rays, compiled=compiled)
    assert caster.cast(0.0, 0.1, 1.0, 0.0) == [0.0, 0.0]
    block = pymunk.Poly(space.static_body, [(1.5, 0.5), (2.0, 0.5), (2.0, 1.5), (1.5, 1.5)])
    space.add(block)
    assert caster.cast(1.0, 1.0, 1.0, 0.0) == [0.5, 0.5]
    space.remove(block)
    assert caster.cast(1.0, 1.0, 1.0, 0.0) == [math.inf, math.inf]


def test_no_rays_read_nothing(compiled: bool) -> None:
    space = pymunk.Space()
    assert RaySet(space, pymunk.ShapeFilter(group=1), [], compiled=compiled).cast(0.0, 0.0, 1.0, 0.0) == []


def test_a_cast_keeps_its_space_alive(compiled: bool) -> None:
    """sense() holds only the cast: the space and its shapes must live as long as it does."""
    def cast_only() -> object:
        space = pymunk.Space()
        space.add(pymunk.Segment(space.static_body, (1.0, -1.0), (1.0, 1.0), 0.05))
        return RaySet(space, pymunk.ShapeFilter(group=1), [SonarRay(0.0, 0.0, 2.0, 0.0, 2.0)], compiled=compiled).cast

    cast = cast_only()
    gc.collect()
    assert cast(0.0, 0.0, 1.0, 0.0) == [0.95]  # type: ignore[operator]


def test_the_wall_lab_runs_the_same_with_either_caster(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Two simulated minutes of the wall lab (its sonar cones, contacts and all): the trace is
    byte for byte the same with the C kernel and with the Python rays."""
    kernel_built(ray_cast.KERNEL)
    traces = []
    for name, kernel in (("c", ray_cast._kernel), ("python", None)):
        monkeypatch.setattr(ray_cast, "_kernel", kernel)
        trace = tmp_path / f"{name}.csv"
        run = compile_behaviour(BEHAVIOURS / "wall_follow.yaml", {"minutes": "2"}).bind(
            load_backend("pymunk"), trace=str(trace), warn=lambda m: None)
        run.run()
        run.close()
        traces.append(trace.read_bytes())
    assert len(traces[0]) > 10_000 and traces[0] == traces[1]


def _mixed(seed: int, compiled: bool) -> tuple[list[list[float]], list[list[float]], list[list[float]],
                                                list[list[float]]]:
    """Ten poses of a random world for a robot with sonars, IR rays and a lidar (some poses
    inside a shape, some in a wall's band): the joined caster's readings, the sonars' and IR
    rays' alone, the lidar's alone, and chipmunk's casts of every beam."""
    rng = random.Random(seed)
    space, bodies = random_world(rng, 3, 3, 1)
    me, rays, f = bodies[0], _rays(rng), pymunk.ShapeFilter(group=1)
    beams = rng.choice([1, 7, 90, 360])
    angles = [rng.uniform(-math.pi, math.pi) for _ in range(beams)]
    mount, reach = rng.uniform(-0.1, 0.2), rng.uniform(1.0, 6.0)
    lidar = LidarFan(space, me, f, angles, mount, reach, compiled=compiled)
    joined = RaySet(space, f, rays, lidar=lidar, compiled=compiled)
    alone = RaySet(space, f, rays, compiled=compiled)
    fan = RaySet(space, f, [], lidar=LidarFan(space, me, f, angles, mount, reach, compiled=compiled),
                 compiled=compiled)
    got, sonars, scans, want = [], [], [], []
    for _ in range(10):
        me.position += (rng.uniform(-0.6, 0.6), rng.uniform(-0.6, 0.6))
        me.angle += rng.uniform(-1, 1)
        for other in bodies[1:]:
            other.position += (rng.uniform(-0.3, 0.3), 0.0)
            other.angle += 0.3
        for body in bodies:
            space.reindex_shapes_for_body(body)
        (x, y), a = me.position, me.angle
        c, s = math.cos(a), math.sin(a)
        got.append(joined.cast(x, y, c, s))
        sonars.append(alone.cast(x, y, c, s))
        scans.append(fan.cast(x, y, c, s))
        want.append(lidar.cast_through_chipmunk(x, y, a))
    return got, sonars, scans, want


def test_a_robots_lidar_is_cast_in_the_same_call_as_its_other_rays(compiled: bool) -> None:
    """The joined caster's readings are the sonars' and IR rays' then the beams', each bit for
    bit what the caster reads for them alone, and the beams what chipmunk reads (to 1e-12 m, as
    tests/contract/test_lidar_fan.py has it for the fan)."""
    inside = 0
    for seed in range(60):
        got, sonars, scans, want = _mixed(seed, compiled)
        for row, sonar, scan, chipmunks in zip(got, sonars, scans, want):
            assert row == sonar + scan, seed
            assert scan == pytest.approx(chipmunks, abs=1e-12, rel=0), seed
            inside += scan == [0.0] * len(scan)
    assert inside > 0  # a lidar inside a shape was tried


def test_a_lidar_with_another_filter_than_its_robots_rays_is_refused(compiled: bool) -> None:
    space = pymunk.Space()
    lidar = LidarFan(space, pymunk.Body(1, 1), pymunk.ShapeFilter(group=1), [0.0, 1.0], 0.0, 5.0, compiled=compiled)
    with pytest.raises(ValueError, match=r"^a lidar is cast with its robot's ray filter$"):
        RaySet(space, pymunk.ShapeFilter(group=2), [], lidar=lidar, compiled=compiled)


def test_the_kernel_casts_a_lidar_as_the_python_rays_and_numpy_do() -> None:
    kernel_built(ray_cast.KERNEL)
    for seed in range(60, 90):
        by_kernel, by_python = _mixed(seed, True), _mixed(seed, False)
        assert by_kernel[1] == by_python[1], seed  # the sonars and IR rays: bit for bit
        for kernel_row, python_row in zip(by_kernel[0], by_python[0]):
            assert kernel_row == pytest.approx(python_row, abs=1e-12, rel=0), seed


def _two_pioneers() -> tuple[list[list[list[object]]], tuple[str, ...]]:
    """Twenty ticks of two Pioneers with their sonar cones and a 90-beam lidar each, driving
    arcs in a room with a wall: sense()'s rows, and the channels each robot reads (the lidar's
    beams not in one run: the first apart from the others)."""
    model = dataclasses.replace(PIONEER_P3DX, lidars=(Lidar(90, 270, 4.0),))
    channels = ("sonar3", "lidar1", "sonar5", *(f"lidar{k}" for k in range(2, 91)), "heading", "sonar8")
    walls = tuple(Wall(a, b, 0.1) for a, b in [((-3, -3), (3, -3)), ((3, -3), (3, 3)), ((3, 3), (-3, 3)),
                                                ((-3, 3), (-3, -3)), ((-1, 0), (1, 0))])
    world = World("room", "a room with a wall", (-3.0, -3.0, 3.0, 3.0), walls)
    backend = load_backend("pymunk")
    backend.open(world, [RobotRequest(f"p[{i}]", model, Pose(-1.5 + 2 * i, 0.8, 0.3), channels)
                         for i in range(2)], 0.05, 1)
    rows = []
    for _ in range(20):
        backend.act(0, 2.0, 1.0)
        backend.act(1, 1.0, 2.0)
        rows.append(backend.sense())
        backend.step()
    backend.close()
    return rows, channels


def test_sense_casts_a_robots_sonars_and_lidar_in_one_call_a_tick(monkeypatch: pytest.MonkeyPatch) -> None:
    """One call of the kernel per robot and tick, the lidar's beams in it; the rows are the
    Python rays' and numpy fan's: the sonars and the rest bit for bit, the beams to 1e-12 m."""
    kernel_built(ray_cast.KERNEL)
    calls = []
    kernel = ray_cast._kernel
    assert kernel is not None

    def counted(*args: object) -> list[float]:
        calls.append(len(args))
        return kernel(*args)

    monkeypatch.setattr(ray_cast, "_kernel", counted)
    by_kernel, channels = _two_pioneers()
    assert calls == [16] * 40  # every call with the lidar's arguments: one a robot and tick
    monkeypatch.setattr(ray_cast, "_kernel", None)
    by_python, _ = _two_pioneers()
    beams = [k for k, name in enumerate(channels) if name.startswith("lidar")]
    seen = 0
    for kernel_rows, python_rows in zip(by_kernel, by_python):
        for kernel_row, python_row in zip(kernel_rows, python_rows):
            assert len(kernel_row) == len(channels)
            assert [v for k, v in enumerate(kernel_row) if k not in beams] == \
                [v for k, v in enumerate(python_row) if k not in beams]
            assert [kernel_row[k] for k in beams] == pytest.approx([python_row[k] for k in beams], abs=1e-12, rel=0)
            seen += sum(math.isfinite(cast(float, kernel_row[k])) for k in beams)
    assert seen > 1000


@pytest.mark.parametrize("lidar", [False, True], ids=["sonars", "sonars and lidar"])
def test_a_robot_that_reads_only_its_rays_gets_the_casters_new_list_each_tick(lidar: bool) -> None:
    """Its row is the caster's list itself: a new one each tick (the runtime may keep it), and
    the same values as a robot at the same pose reading the same rays and one more channel."""
    model = dataclasses.replace(PIONEER_P3DX, lidars=(Lidar(30, 180, 4.0),) if lidar else ())
    rays = tuple(s.name for s in model.sonars) + tuple(f"lidar{k}" for k in range(1, 31) if lidar)
    walls = (Wall((2.0, -2.0), (2.0, 2.0), 0.1), Wall((-2.0, 1.0), (2.0, 1.0), 0.1))
    world = World("room", "two walls", (-3.0, -3.0, 3.0, 3.0), walls)
    rows = []
    for channels in (rays, (*rays, "x")):
        backend = load_backend("pymunk")
        backend.open(world, [RobotRequest("a", model, Pose(0.5, 0.0, 0.4), channels)], 0.05, 1)
        rows += [backend.sense()[0], backend.sense()[0]]
        backend.close()
    assert rows[0] == rows[1] and rows[0] is not rows[1]
    assert any(math.isfinite(v) for v in rows[0])
    assert rows[2] == [*rows[0], 0.5]
