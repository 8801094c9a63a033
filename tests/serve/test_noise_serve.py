"""Noise through ``labsim serve``: the runtime applies it, so the coppeliasim backend gives the
embedded backend's noisy trace, row for row (sonar dropout and jitter, wheel slip, camera noise)."""
from __future__ import annotations

from pathlib import Path

import pytest

pytest.importorskip("cbor2")
pytest.importorskip("zmq")
pytest.importorskip("coppeliasim_zmqremoteapi_client")

from helpers import BEHAVIOURS, FIXTURES, serve_and_run

pytestmark = pytest.mark.slow  # runs through labsim serve processes


def test_sonar_and_wheel_noise_are_the_same_through_labsim_serve(tmp_path: Path) -> None:
    ref, remote = serve_and_run(tmp_path, FIXTURES / "noise.yaml")
    assert remote == ref and len(ref) == 1 + 100 + 1  # the header, 100 ticks, the stopping tick (1.1)
    sonar5 = [row.split(",")[9] for row in ref[1:]]
    assert "inf" in sonar5 and any(v != "inf" for v in sonar5)  # echoes from the wall, and dropouts


def test_camera_noise_is_the_same_through_labsim_serve(tmp_path: Path) -> None:
    lab = tmp_path / "road.yaml"
    text = (BEHAVIOURS / "road_follow.yaml").read_text().replace("seconds: 30 ", "seconds: 1")
    text = text.replace("    at: spawn\n", "    at: spawn\n    noise: {camera: {std: 20}, wheels: {slip: 0.2}}\n")
    lab.write_text(text)
    ref, remote = serve_and_run(tmp_path, lab, "--for", str(lab))
    assert remote == ref and len(ref) == 1 + 5 * 20
    clean = tmp_path / "clean.yaml"
    clean.write_text(text.replace("    noise: {camera: {std: 20}, wheels: {slip: 0.2}}\n", ""))
    quiet, _ = serve_and_run(tmp_path, clean, "--for", str(clean))
    assert quiet != ref  # the noise changed what the cameras saw and where the robots went
