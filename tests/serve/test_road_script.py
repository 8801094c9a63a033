"""A CoppeliaSim-style road-following script against ``labsim serve --for road_follow.yaml``.

The script is written as for CoppeliaSim: two ``RemoteAPIClient`` instances (one steps the
simulation, one serves the robots), one class per robot, ``sim.getVisionSensorImg``, the
image reshaped to 128 x 128 x 3 and used as it comes (no flip: labsim's rows run bottom
first, as CoppeliaSim's do), gray, ``cv2.threshold(gray, 20, 225, 0)``, ``cv2.moments``, the
PID on 64 - cy, stepping until 30 s. All five robots end on the road.
"""
from __future__ import annotations

import subprocess
import sys

import pytest
from helpers import BEHAVIOURS, FIXTURES, PATIENCE_S, serve

pytest.importorskip("cv2")
pytest.importorskip("zmq")
pytest.importorskip("coppeliasim_zmqremoteapi_client")


from labsim.backends.scene.ground import RoadTracker
from labsim.backends.scene.world import builtin_worlds, first_road
from labsim.backends.scene.world_file import load_world
from labsim.foundation.diagnostics import Report

pytestmark = pytest.mark.slow  # a 30-second run of five camera robots through labsim serve

SCRIPT = FIXTURES / "road_script.py"


def test_the_road_script_keeps_five_robots_on_the_road() -> None:
    proc, port = serve("-q", "--for", str(BEHAVIOURS / "road_follow.yaml"))
    try:
        out = subprocess.run([sys.executable, str(SCRIPT), str(port)], capture_output=True, text=True,
                             timeout=60 * PATIENCE_S)
    finally:
        proc.terminate()
        proc.wait(PATIENCE_S)
    assert out.returncode == 0, out.stderr
    world = load_world(builtin_worlds()["road_loop"], Report())
    road = first_road(world)
    assert world is not None and road is not None
    tracker = RoadTracker(road)
    ends = [tuple(map(float, line.split())) for line in out.stdout.split("\n") if line]
    assert len(ends) == 5
    for x, y in ends:
        assert abs(tracker.offset(x, y)) < 0.75, ends  # the road is 3 m wide
