"""The pymunk backend's step() (``chipmunk.WheelDrives.stepper``, built once at open) against
the step it replaces: chipmunk's step, ``WheelDrives.after_step`` and the contact time, each
sub-step, written out here. Robots driven into walls and into each other, so that bodies are
held under their velocity callback and released again: the poses, the velocities and the
contacts are the same bit for bit, for one robot and for three, with one sub-step and two."""
from __future__ import annotations

import pytest

from labsim.backends.protocol import RobotRequest
from labsim.backends.pymunk import chipmunk
from labsim.backends.pymunk.backend import PymunkBackend
from labsim.backends.scene.models import PIONEER_P3DX
from labsim.backends.scene.world import Pose, Wall, World

DT = 0.05


def _room() -> World:
    walls = tuple(Wall(a, b, 0.1) for a, b in [((-1.5, -1.5), (1.5, -1.5)), ((1.5, -1.5), (1.5, 1.5)),
                                                ((1.5, 1.5), (-1.5, 1.5)), ((-1.5, 1.5), (-1.5, -1.5))])
    return World("room", "a small room", (-1.5, -1.5, 1.5, 1.5), walls)


def _by_hand(backend: PymunkBackend, substeps: int) -> None:
    """One tick of the step as it was written before the closure."""
    sim = backend._sim
    space, touching, h = sim._c_space, sim._touching, DT / substeps  # type: ignore[attr-defined]
    for _ in range(substeps):
        chipmunk.space_step(space, h)
        sim._drives.after_step(touching)  # type: ignore[attr-defined]
        for r, t in enumerate(touching):
            if t:
                sim._time_s[r] += h  # type: ignore[attr-defined]


def _history(robots: int, substeps: int, by_hand: bool) -> list[object]:
    starts = [Pose(-0.8 + 0.8 * i, -0.5 + 0.4 * i, 0.7 * i) for i in range(robots)]
    backend = PymunkBackend(substeps)
    backend.open(_room(), [RobotRequest(f"p[{i}]", PIONEER_P3DX, p, ("x",)) for i, p in enumerate(starts)], DT, 1)
    out: list[object] = []
    for tick in range(600):
        for r in range(robots):  # into the walls and each other, backing off now and then
            back = (tick // 90 + r) % 3 == 2
            backend.act(r, -4.0 if back else 6.0, -3.0 if back else 5.0 + r)
        if by_hand:
            _by_hand(backend, substeps)
        else:
            backend.step()
        out.append([(b.position.x, b.position.y, b.angle, b.velocity.x, b.velocity.y, b.angular_velocity)
                    for b in backend.bodies])
    out.append([backend.contacts(r) for r in range(robots)])
    backend.close()
    return out


@pytest.mark.parametrize("substeps", [1, 2])
@pytest.mark.parametrize("robots", [1, 3])
def test_step_moves_the_robots_as_the_step_it_replaces(robots: int, substeps: int) -> None:
    got, want = _history(robots, substeps, False), _history(robots, substeps, True)
    assert got == want
    contacts = got[-1]
    assert isinstance(contacts, list) and all(c.count >= 2 and c.time_s > 0.5 for c in contacts)
