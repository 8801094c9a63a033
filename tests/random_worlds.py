"""For the ray casters' contract tests (tests/contract/test_ray_cast.py and test_lidar_fan.py):
random rooms (static segments, boxes and discs, and a few robots of one footprint, each in a
shape filter group of its own, so that a robot's own rays pass through its body), and the
skip of a kernel test where the C kernel was not built (a failure under CI)."""
from __future__ import annotations

import os
import random

import pymunk
import pytest

HOW = ("the C kernel backends/pymunk/_fan.c was not built: `pip install .` builds it where a C compiler is "
       "(an editable checkout: `pip install -e .`, or `python -c \"from setuptools import setup; setup()\" "
       "build_ext --inplace` in the repository)")
FOOTPRINT = [(-0.2, -0.15), (0.25, -0.15), (0.3, 0.0), (0.25, 0.15), (-0.2, 0.15)]


def random_world(rng: random.Random, span: float, reach: float, box: float) -> tuple[pymunk.Space, list[pymunk.Body]]:
    """A space of walls within ``span`` m of the origin (each up to ``reach`` m long), boxes up to
    ``box`` m in half-size, discs, and 1 to 3 robots; the robots' bodies."""
    space = pymunk.Space()
    for _ in range(rng.randint(1, 12)):
        a = (rng.uniform(-span, span), rng.uniform(-span, span))
        b = (a[0] + rng.uniform(-reach, reach), a[1] + rng.uniform(-reach, reach))
        space.add(pymunk.Segment(space.static_body, a, b, rng.choice([0.0, 0.05, rng.uniform(0, 0.3)])))
    for _ in range(rng.randint(0, 4)):
        x, y, w, h = rng.uniform(-span, span), rng.uniform(-span, span), rng.uniform(0.1, box), rng.uniform(0.1, box)
        corners = [(x - w, y - h), (x + w, y - h), (x + w, y + h), (x - w, y + h)]
        space.add(pymunk.Poly(space.static_body, corners, radius=rng.choice([0.0, 0.0, 0.1])))
    for _ in range(rng.randint(0, 2)):
        space.add(pymunk.Circle(space.static_body, rng.uniform(0.05, 1),
                                (rng.uniform(-span, span), rng.uniform(-span, span))))
    bodies = []
    for group in range(1, rng.randint(2, 5)):
        body = pymunk.Body(1, 1)
        body.position, body.angle = (rng.uniform(-span, span), rng.uniform(-span, span)), rng.uniform(-4, 4)
        shape = pymunk.Poly(body, FOOTPRINT)
        shape.filter = pymunk.ShapeFilter(group=group)
        space.add(body, shape)
        bodies.append(body)
    return space, bodies


def kernel_built(kernel: str) -> None:
    """Skip a test of the kernel where it was not built (``kernel`` is not "c"); under CI, fail it."""
    if kernel != "c":
        if os.environ.get("CI", "").lower() == "true":
            pytest.fail(HOW)
        pytest.skip(HOW)
