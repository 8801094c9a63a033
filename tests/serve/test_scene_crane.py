"""``labsim scene`` builds the crane's mechanism; ``labsim serve --empty`` reads it back, and the
crane's run there gives the run of ``labsim serve crane`` and the embedded run, row for row."""
from __future__ import annotations

from pathlib import Path

import pytest

pytest.importorskip("zmq")
pytest.importorskip("coppeliasim_zmqremoteapi_client")

from helpers import BEHAVIOURS, serve, stop, trace_rows

from labsim.backends.scene.world import World, builtin_worlds
from labsim.backends.scene.world_file import load_world
from labsim.foundation.diagnostics import Report
from labsim.runtime.cli.main import main
from labsim.runtime.serve.server import Server

pytestmark = pytest.mark.slow  # the crane built in a labsim serve process, and run there

CRANE = BEHAVIOURS / "crane.yaml"


def test_the_built_crane_is_the_world_files_mechanism() -> None:
    """What labsim scene sends comes back as the world file's mechanism, number for number."""
    from labsim.backends.coppeliasim.connection import Connection
    from labsim.runtime.builder.scene import build

    world = load_world(builtin_worlds()["crane"], Report())
    assert world is not None and world.mechanism is not None
    with Server(World("none", "", (0, 0, 1, 1)), 0, port=0, empty=True) as srv:
        build(Connection("127.0.0.1", srv.port, 5.0), world, [], 0.05)
        assert srv.editor is not None
        built = srv.editor.world()
    assert built.mechanism == world.mechanism and built.walls == () and built.blocks == ()


def test_the_crane_built_by_labsim_scene_gives_labsim_serve_cranes_trace(empty: int, tmp_path: Path,
                                                                      capsys) -> None:
    assert main(["scene", str(CRANE), "--port", str(empty)]) == 0
    out = capsys.readouterr().out
    assert "the mechanism, 8 bodies, 5 joints and 1 force sensors" in out
    built, served = tmp_path / "built.csv", tmp_path / "served.csv"
    assert main(["run", str(CRANE), "-q", "--trace", str(built), "--backend", "coppeliasim",
                 "--port", str(empty)]) == 0
    proc, port = serve("-q", "crane", "--robots", "0")
    try:
        assert main(["run", str(CRANE), "-q", "--trace", str(served),
                     "--backend", "coppeliasim", "--port", str(port)]) == 0
    finally:
        stop(proc)
    assert trace_rows(built) == trace_rows(served) and len(trace_rows(built)) == 1 + 1201  # format 1.2: tick 1200 too
    embedded = tmp_path / "embedded.csv"
    assert main(["run", str(CRANE), "-q", "--trace", str(embedded)]) == 0
    assert trace_rows(built) == trace_rows(embedded)  # after the slew too: frames._unslewed
    assert main(["test", str(CRANE), "--backend", "coppeliasim", "--port", str(empty)]) == 0
