"""Seeded noise (labsim.dsl.syntax.noise, labsim.runtime.noise): the models' statistics, determinism under
the seed, a separate stream from the behaviour's own random draws, and no change without it."""
from __future__ import annotations

import itertools
import json
import math
import re
import statistics
from pathlib import Path

import numpy as np
import pytest
from helpers import BENCHMARKS, DOCS, FIXTURES

from labsim.backends import load_backend
from labsim.dsl.syntax.noise import Noise
from labsim.runtime.cli.report import format_summary
from labsim.runtime.noise import Draws, NoisyIO, RobotNoise
from labsim.runtime.run import compile_behaviour
from labsim.runtime.trace import read_trace

N = 20_000  # draws for each statistic: the standard error of a mean is under 1% of its std

# A robot 0.75 m from the east wall, facing it, standing still: sonar4 and sonar5 see the wall.
STILL = """\
labsim: 1.1
world: walls_lab4
seed: {seed}
stop: time >= {seconds}
robots:
  pioneer:
    model: pioneer_p3dx
    at: [6.5, 0, 0]
{noise}let:
  r: randint(0, 1000)
  ahead: sonar5
  side: sonar4
rules:
  - always move({speed})
"""


def _io(noise: Noise, readings: list[object], sonars: list[tuple[int, float]], cameras: tuple[int, ...] = (),
        seed: str = "0") -> tuple[NoisyIO, list[tuple[int, float, float]]]:
    """A NoisyIO over a fake backend that always reads ``readings``; acts are collected."""
    sent: list[tuple[int, float, float]] = []
    robot = RobotNoise(0, "pioneer", noise, 12.3, sonars, list(cameras), Draws(seed), np.random.default_rng(0))
    io = NoisyIO([robot], lambda: [list(readings)], lambda i, a, b: sent.append((i, a, b)), lambda: None)
    return io, sent


def test_sonar_noise_is_gaussian_with_the_declared_std() -> None:
    io, _ = _io(Noise(sonar_std_m=0.05), [0.5, math.inf, True], [(0, 1.0), (1, 1.0)])
    seen = [io.sense()[0] for _ in range(N)]
    echoes = [v[0] for v in seen]
    assert statistics.fmean(echoes) == pytest.approx(0.5, abs=0.002)
    assert statistics.stdev(echoes) == pytest.approx(0.05, rel=0.03)
    assert all(v[1] == math.inf and v[2] is True for v in seen)  # no echo stays none; others untouched


def test_sonar_dropout_rate_and_range() -> None:
    io, _ = _io(Noise(sonar_dropout=0.2), [0.5], [(0, 1.0)])
    lost = sum(io.sense()[0][0] == math.inf for _ in range(N))
    assert lost / N == pytest.approx(0.2, abs=0.01)  # 3.5 standard errors
    assert io.robots[0].dropped == lost and "lost" in io.summary()["pioneer"]
    # noise past the sonar's range is no echo; below 0 reads 0
    far, _ = _io(Noise(sonar_std_m=0.5), [0.99], [(0, 1.0)])
    values = [far.sense()[0][0] for _ in range(2000)]
    assert math.inf in values and min(values) >= 0 and max(v for v in values if v != math.inf) <= 1.0


def test_camera_noise_per_pixel() -> None:
    image = np.full((32, 32, 3), 100, np.uint8)
    io, _ = _io(Noise(camera_std=8), [image], [], cameras=[0])
    noisy = io.sense()[0][0]
    assert isinstance(noisy, np.ndarray) and noisy.dtype == np.uint8 and noisy.shape == image.shape
    assert float(noisy.mean()) == pytest.approx(100, abs=0.5)
    assert float(noisy.std()) == pytest.approx(8, rel=0.05)
    assert (image == 100).all()  # the backend's image is left as it was


def test_wheel_noise_and_slip_are_drawn_every_tick_and_clamped() -> None:
    io, sent = _io(Noise(wheel_std_rad_s=0.3), [], [])
    io.act(0, 5.0, -5.0)
    for _ in range(N):
        io.step()
    left = [a for _, a, _ in sent]
    assert len(sent) == N  # sent before every step, with fresh noise
    assert statistics.fmean(left) == pytest.approx(5.0, abs=0.01)
    assert statistics.stdev(left) == pytest.approx(0.3, rel=0.03)
    io, sent = _io(Noise(wheel_slip=0.2), [], [])
    io.act(0, 10.0, 10.0)
    for _ in range(N):
        io.step()
    right = [b for _, _, b in sent]
    assert statistics.fmean(right) == pytest.approx(9.0, abs=0.02)  # loses 10% on average
    assert statistics.stdev(right) == pytest.approx(10 * 0.2 / math.sqrt(12), rel=0.03)
    assert min(right) >= 8.0 and max(right) <= 10.0
    io, sent = _io(Noise(wheel_std_rad_s=5), [], [])
    io.act(0, 12.3, -12.3)
    io.step()
    assert all(abs(v) <= 12.3 for _, a, b in sent for v in (a, b))


def _run(write, *, seed: int = 1, seconds: float = 20, noise: str = "", speed: float = 0,
         backend: str = "pymunk", **options: object) -> tuple[Path, str]:
    path = write(STILL.format(seed=seed, seconds=seconds, noise=noise, speed=speed), f"b{next(_NAMES)}.yaml")
    trace = path.with_suffix(".csv")
    run = compile_behaviour(path).bind(load_backend(backend, **options), trace=trace)
    try:
        summary = run.run()
        text = format_summary(summary)
    finally:
        run.close()
    return trace, text


_NAMES = itertools.count()
SONAR = "    noise:\n      sonar: {std_m: 0.02, dropout: 0.1}\n"
WHEELS = "    noise:\n      wheels: {std_rad_s: 0.5, slip: 0.2}\n"


def test_a_run_with_sonar_noise_reads_the_wall_with_the_declared_statistics(write) -> None:
    clean, _ = _run(write)
    truth = float(read_trace(clean).column("ahead")[0])
    assert set(read_trace(clean).column("ahead")) == {read_trace(clean).column("ahead")[0]}
    noisy, text = _run(write, noise=SONAR)
    readings = [float(v) for v in read_trace(noisy).column("ahead")]
    echoes = [v for v in readings if v != math.inf]
    assert len(readings) == 401  # 20 s of 0.05 s ticks, and the stopping tick a 1.1 file traces
    assert 1 - len(echoes) / len(readings) == pytest.approx(0.1, abs=0.05)
    assert statistics.fmean(echoes) == pytest.approx(truth, abs=0.005)
    assert statistics.stdev(echoes) == pytest.approx(0.02, rel=0.15)
    assert "noise: pioneer: sonar 0.02 m, 10% dropout (" in text and "sonar readings lost)" in text
    header = json.loads(noisy.read_text().split("\n", 1)[0].removeprefix("# labsim-trace "))
    assert header["noise"] == {"pioneer": {"sonar": {"std_m": 0.02, "dropout": 0.1}}}


def test_noise_is_deterministic_under_the_seed_and_apart_from_the_behaviours_draws(write) -> None:
    a, _ = _run(write, noise=SONAR + "      wheels: {std_rad_s: 0.5, slip: 0.2}\n", speed=2)
    b, _ = _run(write, noise=SONAR + "      wheels: {std_rad_s: 0.5, slip: 0.2}\n", speed=2)
    assert a.read_text().split("\n", 1)[1] == b.read_text().split("\n", 1)[1]
    other, _ = _run(write, seed=2, noise=SONAR + "      wheels: {std_rad_s: 0.5, slip: 0.2}\n", speed=2)
    assert read_trace(other).column("x") != read_trace(a).column("x")
    # the behaviour's randint() draws the same numbers with or without noise
    clean, _ = _run(write, speed=2)
    assert read_trace(clean).column("r") == read_trace(a).column("r")
    # wheel noise moves the robot off the noiseless path
    assert read_trace(clean).column("x") != read_trace(a).column("x")


def test_a_run_without_noise_has_no_noise_anywhere(write) -> None:
    path = write(STILL.format(seed=1, seconds=1, noise="", speed=1))
    run = compile_behaviour(path).bind(load_backend("pymunk"), trace=path.with_suffix(".csv"))
    try:
        assert run.noise is None and run.sense == run.backend.sense  # no wrapper, no cost
        text = format_summary(run.run())
    finally:
        run.close()
    assert "  noise:" not in text and '"noise"' not in path.with_suffix(".csv").read_text()
    # an empty declaration is none
    quiet = write(STILL.format(seed=1, seconds=1, noise="    noise: {}\n", speed=1), "q.yaml")
    assert compile_behaviour(quiet).program.robots[0].noise is None


def test_the_noise_fixture_reads_every_model() -> None:
    program = compile_behaviour(FIXTURES / "noise.yaml").program
    assert program.robots[0].noise == Noise(sonar_std_m=0.02, sonar_dropout=0.05, wheel_std_rad_s=0.2,
                                            wheel_slip=0.1)


def test_the_docs_noise_example_runs(write) -> None:
    doc = (DOCS / "language.md").read_text()
    (text,) = re.findall(r"```yaml\n(# noise example: noisy_wall\n.*?)```", doc, re.S)
    trace = write(text, "noisy_wall.yaml").with_suffix(".csv")
    run = compile_behaviour(trace.with_suffix(".yaml")).bind(load_backend("pymunk"), trace=trace)
    try:
        summary = run.run()
        shown = format_summary(summary)
    finally:
        run.close()
    assert "noise: pioneer: sonar 0.02 m, 5% dropout; wheels 0.2 rad/s, up to 10% slip (" in shown
    assert 0 < summary.robots["pioneer"].metrics["closest"] < 0.6  # it found the wall and turned
    assert summary.rule_counts["main:1"] > 0
    # the docs' way to bridge a dropout compiles and holds the last echo
    bridged = write(text.replace("min(sonar4, sonar5)", "remember(sonar5, sonar5 < inf)"), "bridged.yaml")
    assert compile_behaviour(bridged).program.let_names == ("ahead",)


def test_the_json_summary_has_each_robots_noise(capsys: pytest.CaptureFixture[str]) -> None:
    from labsim.runtime.cli.main import main

    assert main(["run", str(FIXTURES / "noise.yaml"), "-q", "--json"]) == 0
    robot = json.loads(capsys.readouterr().out)["robots"]["pioneer"]
    assert robot["noise"] == {"sonar": {"std_m": 0.02, "dropout": 0.05}, "wheels": {"std_rad_s": 0.2, "slip": 0.1}}
    assert robot["sonar_readings_lost"] > 0
    assert main(["run", str(FIXTURES / "minimal.yaml"), "-q", "--json"]) == 0
    robot = json.loads(capsys.readouterr().out)["robots"]["pioneer"]
    assert robot["noise"] == {} and robot["sonar_readings_lost"] == 0


@pytest.mark.slow
def test_the_noise_benchmark_runs() -> None:
    """Runs once, briefly; the figure it prints is not checked (shared machines are noisy)."""
    import subprocess
    import sys

    script = BENCHMARKS / "bench_noise.py"
    done = subprocess.run([sys.executable, str(script), "--repeat", "1", "--minutes", "0.2"],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert "wall lab, 240 ticks" in done.stdout and "noise / no noise: median of per-round ratios" in done.stdout
