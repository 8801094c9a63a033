"""Channels the behaviour and the trace both read: read once, the same value in both.

The trace records every robot's ``x``, ``y``, ``heading`` and ``collided``; a behaviour may
read the same channels. The runtime asks the backend for each name once and takes both from
that one reading, on every backend (the coppeliasim backend through ``labsim serve``). Each
behaviour copies the channel into a signal, which the trace records beside the channel's own
column: the two columns agree on every row, and ``collided`` is true while the robot pushes
against the east wall.
"""
from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from labsim.backends.protocol import RobotRequest
from labsim.backends.scene.models import PIONEER_P3DX
from labsim.backends.scene.world import Pose
from labsim.runtime.cli.main import main
from labsim.runtime.trace import read_trace

POSE = ("x", "y", "heading", "collided")
BACKENDS = ("pymunk", "coppeliasim")
# 0.7 m from the east wall, heading for it: it touches the wall after about 1.5 s
BEHAVIOUR = """\
labsim: 1
name: reads {channel}
world: walls_lab4
dt: 0.05
seed: 1
stop: time >= 3 or x > 100
robots:
  pioneer: {{model: pioneer_p3dx, at: [6.8, 0.0, 0]}}
let:
  seen: {channel}
rules:
  - always move(3)
"""


@pytest.fixture(scope="module")
def port() -> Iterator[int]:
    """A stand-in CoppeliaSim (walls_lab4, one robot) in a thread."""
    pytest.importorskip("zmq")
    pytest.importorskip("cbor2")
    pytest.importorskip("coppeliasim_zmqremoteapi_client")
    from labsim.backends.scene.world import builtin_worlds
    from labsim.backends.scene.world_file import load_world
    from labsim.foundation.diagnostics import Report
    from labsim.runtime.serve.server import Server

    with Server(load_world(builtin_worlds()["walls_lab4"], Report()), 1, port=0) as srv:
        yield srv.port


def _options(backend: str, request: pytest.FixtureRequest) -> list[str]:
    if backend == "pymunk":
        return []
    return ["--backend", "coppeliasim", "--port", str(request.getfixturevalue("port"))]


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("channel", POSE)
def test_a_channel_read_by_behaviour_and_trace_lands_in_both(
        channel: str, backend: str, tmp_path: Path, request: pytest.FixtureRequest, capsys) -> None:
    lab = tmp_path / f"{channel}.yaml"
    lab.write_text(BEHAVIOUR.format(channel=channel))
    trace = tmp_path / f"{channel}.csv"
    assert main(["run", str(lab), "-q", "--trace", str(trace), *_options(backend, request)]) == 0, \
        capsys.readouterr().err
    t = read_trace(trace)
    seen, recorded = t.column("seen"), t.column(channel)
    assert len(recorded) == 60 and seen == recorded
    if channel == "collided":
        assert "1" in recorded and recorded[0] == "0"  # it reaches the wall, and says so
    # the golden check on the same file, recorded on pymunk, passes on the backend too
    assert main(["test", str(lab), "--update-goldens"]) == 0
    assert main(["test", str(lab), *_options(backend, request)]) == 0, capsys.readouterr().out


def test_a_request_naming_a_channel_twice_is_refused() -> None:
    with pytest.raises(ValueError, match="x twice"):
        RobotRequest("a", PIONEER_P3DX, Pose(0, 0, 0), ("x", "sonar5", "x"))
