"""Images, centroids, PID and the fleet: the language features of the road-following lab."""
from __future__ import annotations

import numpy as np
import pytest
from fake_backend import FakeBackend

from labsim.backends.scene.models import PIONEER_P3DX
from labsim.dsl.library import images
from labsim.dsl.library.support import make_pid
from labsim.foundation.diagnostics import LabsimError
from labsim.runtime.cli.report import format_summary
from labsim.runtime.run import compile_behaviour

CAMERA = "camera: {resolution: [8, 6], fov_deg: 60, height_m: 0.3, pitch_deg: 45}"
HEAD = ("labsim: 1\nworld: walls_lab4\ndt: 0.05\nseed: 1\nrobots:\n"
        f"  p: {{model: pioneer_p3dx, at: [0, 0, 0], {CAMERA}}}\n")


def frame(columns: slice, rows: slice = slice(None), shape=(6, 8)) -> np.ndarray:
    """A dark RGB frame with a bright rectangle."""
    img = np.full((*shape, 3), 20, np.uint8)
    img[rows, columns] = 200
    return img


def test_image_functions_on_known_images() -> None:
    img = frame(slice(2, 4))  # columns 2 and 3 bright, all rows
    g = images.gray(img)
    assert g.shape == (6, 8) and g[0, 2] == 200 and g[0, 0] == 20
    t = images.threshold(img, 20)  # OpenCV THRESH_BINARY: strictly greater than the level
    assert t[0, 0] == 0 and t[0, 2] == 255
    assert images.area(t) == 12
    assert images.centroid(t) == (2.5, 2.5, True)
    assert images.centroid(images.invert(t))[0] == pytest.approx((0 + 1 + 4 + 5 + 6 + 7) / 6)
    assert images.mean(images.crop(t, 2, 0, 2, 6)) == 255
    assert (images.width(img), images.height(img)) == (8, 6)
    with pytest.raises(ValueError):
        images.crop(t, 10, 10, 2, 2)
    with pytest.raises(images.EmptyCentroid) as e:
        images.centroid(np.zeros((6, 8), np.uint8))
    assert e.value.result == (3.5, 2.5, False)


def run(write, body: str, script, ticks: int = 100, **kw):
    behaviour = compile_behaviour(write(HEAD + body))
    backend = FakeBackend(script)
    warnings: list[str] = []
    r = behaviour.bind(backend, warn=warnings.append, **kw)
    summary = r.run(max_ticks=ticks)
    return r, backend, summary, warnings


def test_centroid_steering_and_an_empty_image(write) -> None:
    body = ("stop: tick >= 3\nlet:\n  lane: threshold(gray(camera), 100)\n  c: centroid(lane)\n"
            "  error: width(camera) / 2 - c.x\nrules:\n  - if c.found then wheels(1 - error, 1 + error)\n"
            "  - else stop()\n")
    frames = [frame(slice(5, 7)), frame(slice(0, 0)), frame(slice(1, 2))]
    r, backend, summary, warnings = run(write, body, lambda t, i, ch: frames[min(t, 2)])  # tick 3 senses, then stops
    # tick 0: centroid x 5.5 -> error -1.5; tick 1: empty -> stop; tick 2: x 1 -> error 3
    assert backend.acts == [(0, 0, 2.5, -0.5), (1, 0, 0.0, 0.0), (2, 0, -2.0, 4.0)]
    (w,) = warnings
    assert "centroid of an image with no set pixel (the result is the image centre, .found false)" in w
    assert "in signal 'c', robot p, tick 1" in w


def test_pid_matches_a_hand_computation(write) -> None:
    body = ("stop: tick >= 6\nparams: {kp: 0.05, ki: 0.01, kd: 0.2}\nlet:\n"
            "  out: pid(sonar1, kp, ki, kd)\n  twin: pid(sonar1, kp, ki, kd)\nrules:\n  - always arc(out, twin)\n")
    errors = [10.0, 5.0, -2.0, 0.0, 7.0, 7.0]
    r, backend, summary, _ = run(write, body, {"sonar1": errors})
    integral, previous, expected = 0.0, 0.0, []
    for e in errors:
        integral += e
        expected.append(0.05 * e + 0.01 * integral + 0.2 * (e - previous))
        previous = e
    assert [left for _, _, left, _ in backend.acts] == pytest.approx(expected)
    # each call site keeps its own state, so the twin computes the same sequence
    assert [right for _, _, _, right in backend.acts] == pytest.approx(expected)


def test_pid_limit_clamps_and_stops_winding_up() -> None:
    pid = make_pid(lambda what: None)
    outs = [pid(10.0, 1.0, 1.0, 0.0, 5.0) for _ in range(5)]
    assert outs == [5.0] * 5
    assert pid(-1.0, 1.0, 1.0, 0.0, 5.0) == -2.0  # -1 - 1: the integral did not grow while saturated


def test_pid_state_is_per_robot(write) -> None:
    text = (HEAD.replace("  p: {model: pioneer_p3dx, at: [0, 0, 0], ",
                         "  p: {model: pioneer_p3dx, count: 2, at: spawn, ")
            + "stop: tick >= 4\nlet:\n  out: pid(sonar1, 1, 1, 0)\nrules:\n  - always arc(out, 0)\n")
    behaviour = compile_behaviour(write(text))
    backend = FakeBackend(lambda tick, robot, ch: 1.0 if robot == 0 else 0.0)
    behaviour.bind(backend).run()
    assert [(i, left) for _, i, left, _ in backend.acts] == [(0, 2.0), (1, 0.0), (0, 3.0), (0, 4.0), (0, 5.0)]


def test_drive_uses_the_robot_geometry(write) -> None:
    r, backend, _, _ = run(write, "stop: tick >= 1\nrules:\n  - always drive(0.5, 1)\n", {})
    radius, half = PIONEER_P3DX.wheel_radius_m, PIONEER_P3DX.axle_length_m / 2
    assert backend.acts == [(0, 0, pytest.approx((0.5 - half) / radius), pytest.approx((0.5 + half) / radius))]


def test_images_stay_out_of_the_trace_but_what_is_derived_from_them_is_in(write, tmp_path) -> None:
    body = ("stop: tick >= 2\nlet:\n  c: centroid(threshold(camera, 100))\n  cx: c.x\n"
            "rules:\n  - always stop()\nmetrics:\n  lateral: rms(cx - 3.5)\n")
    path = tmp_path / "t.csv"
    r, _, summary, _ = run(write, body, lambda t, i, ch: frame(slice(5, 7)), trace=path)
    header = path.read_text().splitlines()[1].split(",")
    assert "camera" not in header and "c" not in header and "cx" in header
    assert summary.robots["p"].metrics["lateral"] == pytest.approx(2.0)


def test_more_robots_than_spawn_poses_is_a_check_error(write) -> None:
    path = write("labsim: 1\nworld: walls_lab4\nstop: time >= 1\nrobots:\n"
                 "  p: {model: pioneer_p3dx, count: 6, at: spawn}\nrules:\n  - always stop()\n")
    with pytest.raises(LabsimError) as e:
        compile_behaviour(path)
    (d,) = e.value.diagnostics
    assert (d.line, d.col) == (5, 42)
    assert d.message == "world 'walls_lab4' has 5 spawn poses, too few for 6 robots placed 'at: spawn'"


def test_fleet_summary_has_a_row_per_robot_and_the_fleet(write) -> None:
    text = ("labsim: 1\nworld: walls_lab4\nstop: tick >= 4\nrobots:\n  p: {model: pioneer_p3dx, count: 3, at: spawn}\n"
            "rules:\n  - always stop()\nmetrics:\n  near: count(sonar1 < 1)\n  far: maximum(sonar1)\n")
    behaviour = compile_behaviour(write(text))
    backend = FakeBackend(lambda tick, robot, ch: [0.5, 2.0, 0.5 + tick][robot])
    r = behaviour.bind(backend)
    summary = r.run()
    assert summary.fleet == {"near": 2, "far": 3.5}  # robots 0 and 2 come near once each
    text = format_summary(summary)
    assert "  metrics  near   far" in text
    assert "  fleet      2+  3.5^" in text
