"""Seeded noise between the backend and the compiled program: the same on every backend.

``labsim.runtime.run`` puts a ``NoisyIO`` in front of the backend's ``sense``, ``act`` and
``step`` when a robot of the behaviour declares ``noise:`` (``labsim.dsl.syntax.noise``); a run
without noise never builds one and pays nothing. What the behaviour reads (and the trace
records) is the noisy reading; what the backend receives is the noisy wheel command.

The models, per robot, each tick:

- sonar: each reading is lost with probability ``dropout`` (it reads ``inf``, no echo); an
  echo gets Gaussian noise of ``std_m`` metres, and reads ``inf`` when that puts it beyond
  the sonar's range, 0 when below 0; a sonar that saw nothing stays ``inf``;
- camera: Gaussian noise of ``std`` levels on every colour channel of every pixel, rounded
  and clipped to 0..255;
- lidar (its own ``noise:`` key, ``labsim.dsl.syntax.lidar``): Gaussian noise of that many metres
  on each beam that sees something, ``inf`` beyond the range, 0 below 0, drawn after the
  sonars' draws, one per beam read, every tick;
- wheels: each wheel turns at its command times ``1 - u`` (``u`` uniform in 0..``slip``),
  plus Gaussian noise of ``std_rad_s``, clamped to the model's limit; drawn anew every tick.

Each robot draws from its own generators, seeded from the behaviour's seed and the robot's
name (``"{seed}/{name}/noise"``), apart from the generator of its ``random()`` and
``randint()``: adding noise changes no other draw. Every draw is made whether or not it is
used (a dropout decision and a Gaussian per sonar per tick), so the streams do not depend on
what was sensed. The uniform and the Gaussian numbers are two streams of numpy's generator
(``Draws``), drawn 1024 at a time: a number then costs a step of an iterator, where
``random.gauss`` cost a call of Python code (the noise made a run 1.74x as long).
"""
from __future__ import annotations

import itertools
import math
import random
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from labsim.backends.scene.models import Kind, RobotModel
from labsim.dsl.emit.program import Program
from labsim.dsl.syntax.noise import Noise

if TYPE_CHECKING:  # numpy only for camera noise, imported then: a run without it starts faster
    import numpy as np


_BLOCK = 1024  # numbers drawn from numpy at a time, per stream


class Draws:
    """A robot's noise numbers: ``uniform()`` in [0, 1) and ``normal()`` standard Gaussian, each
    its own stream of numpy's default generator, both seeded from ``seed``."""

    def __init__(self, seed: str) -> None:
        import numpy as np  # only a run with noise pays for its import

        entropy = random.Random(seed).getrandbits(128)
        uniforms, normals = (np.random.default_rng(s) for s in np.random.SeedSequence(entropy).spawn(2))
        self.uniform: Callable[[], float] = _stream(lambda: uniforms.random(_BLOCK).tolist()).__next__
        self.normal: Callable[[], float] = _stream(lambda: normals.standard_normal(_BLOCK).tolist()).__next__


def _stream(block: Callable[[], list[float]]) -> Iterator[float]:
    """The numbers of block(), block(), ... one after another, for ever."""
    return itertools.chain.from_iterable(iter(block, None))


@dataclass
class RobotNoise:
    """One robot's noise: its models, where its noisy channels sit, its generators and counts."""

    index: int
    name: str
    noise: Noise
    limit: float  # wheel speed limit, rad/s
    sonars: list[tuple[int, float]]  # (position in the robot's readings, range in m)
    cameras: list[int]  # positions of its images in its readings
    draws: Draws
    pixels: np.random.Generator | None  # for camera noise only
    command: list[float] = field(default_factory=lambda: [0.0, 0.0])  # what the runtime last sent, rad/s
    dropped: int = 0  # sonar readings lost so far
    # (position, range in m, noise std in m) of each lidar beam read, when the lidar has noise
    lidar: list[tuple[int, float, float]] = field(default_factory=list)


class NoisyIO:
    """A backend's ``sense``, ``act`` and ``step``, with each robot's noise applied."""

    def __init__(self, robots: list[RobotNoise], sense: Callable[[], list[list[object]]],
                 act: Callable[[int, float, float], None], step: Callable[[], None]) -> None:
        self.robots = robots
        self._sense, self._act, self._step = sense, act, step
        self._sensing = [r for r in robots if r.noise.sonar or r.cameras or r.lidar]
        self._wheels = {r.index: r for r in robots if r.noise.wheels}

    def sense(self) -> list[list[object]]:
        readings = self._sense()
        out = list(readings)  # the backend's lists are left as they are
        for r in self._sensing:
            values = list(readings[r.index])
            self._sonars(r, values)
            if r.lidar:
                self._lidar(r, values)
            for k in r.cameras:
                import numpy as np  # already imported: an image is a numpy array

                image = values[k]
                if isinstance(image, np.ndarray) and r.pixels is not None:
                    noisy = image + r.pixels.normal(0.0, r.noise.camera_std, image.shape)
                    values[k] = np.clip(np.rint(noisy), 0, 255).astype(np.uint8)
            out[r.index] = values
        return out

    @staticmethod
    def _sonars(r: RobotNoise, values: list[object]) -> None:
        uniform, normal, inf = r.draws.uniform, r.draws.normal, math.inf
        dropout, std = r.noise.sonar_dropout, r.noise.sonar_std_m
        for k, range_m in r.sonars:
            lost = uniform() < dropout
            jitter = std * normal() if std else 0.0
            v = values[k]
            if lost:
                values[k] = inf
                r.dropped += 1
            elif isinstance(v, float) and -inf < v < inf:  # an echo (not inf, not NaN)
                v += jitter
                values[k] = inf if v > range_m else v if v > 0.0 else 0.0

    @staticmethod
    def _lidar(r: RobotNoise, values: list[object]) -> None:
        normal = r.draws.normal
        for k, range_m, std_m in r.lidar:
            jitter = std_m * normal()
            v = values[k]
            if isinstance(v, float) and math.isfinite(v):
                v += jitter
                values[k] = math.inf if v > range_m else max(0.0, v)

    def act(self, robot: int, left_rad_s: float, right_rad_s: float) -> None:
        r = self._wheels.get(robot)
        if r is None:
            self._act(robot, left_rad_s, right_rad_s)
        else:
            command = r.command  # sent, with fresh noise, before each step
            command[0], command[1] = left_rad_s, right_rad_s

    def step(self) -> None:
        for r in self._wheels.values():
            uniform, normal, limit = r.draws.uniform, r.draws.normal, r.limit
            slip, std = r.noise.wheel_slip, r.noise.wheel_std_rad_s
            left, right = r.command
            left = left * (1.0 - slip * uniform()) + std * normal()
            right = right * (1.0 - slip * uniform()) + std * normal()
            self._act(r.index, min(limit, max(-limit, left)), min(limit, max(-limit, right)))
        self._step()

    @staticmethod
    def describe(r: RobotNoise) -> str:
        """A noisy robot's models, and the sonar readings lost, for the run's summary."""
        lidar = f"lidar {r.lidar[0][2]:g} m" if r.lidar else ""
        own = r.noise.describe() if r.noise else ""
        return ("; ".join(part for part in (own, lidar) if part) or "none") + (
            f" ({r.dropped} sonar readings lost)" if r.noise.sonar_dropout else "")

    def summary(self) -> dict[str, str]:
        """Each noisy robot's ``describe``, by name."""
        return {r.name: self.describe(r) for r in self.robots}


def noisy(model: RobotModel | None, noise: Noise | None) -> bool:
    """Whether a robot's readings or wheels get noise: its ``noise:``, or its lidar's own."""
    return model is not None and (bool(noise) or any(lidar.noise_std_m > 0 for lidar in model.lidars))


def robot_noise(program: Program, index: int, name: str, model: RobotModel, noise: Noise) -> RobotNoise:
    """A robot's noise, its channels found among the program's and its generators seeded."""
    ranges = {s.name: s.range_m for s in model.sonars}  # a lidar's beams have their own noise
    sonars = [(k, ranges[c]) for k, c in enumerate(program.channels) if c in ranges] if noise.sonar else []
    cameras = [k for k, c in enumerate(program.channels)
               if program.channel_kinds.get(c) is Kind.IMAGE] if noise.camera else []
    beams = {ray.name: (ray.range_m, lidar.noise_std_m) for lidar in model.lidars if lidar.noise_std_m > 0
             for ray in lidar.rays()}
    lidar = [(k, *beams[c]) for k, c in enumerate(program.channels) if c in beams]
    draws = Draws(f"{program.seed}/{name}/noise")
    pixels = None
    if noise.camera:
        import numpy as np

        pixels = np.random.default_rng(random.Random(f"{program.seed}/{name}/camera noise").getrandbits(64))
    return RobotNoise(index, name, noise, model.max_wheel_speed_rad_s, sonars, cameras, draws, pixels, lidar=lidar)
