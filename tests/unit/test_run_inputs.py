"""What a run reads: its behaviour and world files once, when it compiles.

A trace's header names the world's SHA-256; it is the hash of the text the compiler read, not
of the file read again when the trace opens, which another writer may have changed by then
(and reading it twice would count twice against a slow or remote folder).
"""
from __future__ import annotations

import hashlib
from pathlib import Path

from helpers import BEHAVIOURS, ROOT

from labsim.backends import load_backend
from labsim.runtime.run import compile_behaviour
from labsim.runtime.trace import read_trace

WORLD = ROOT / "backends" / "scene" / "worlds" / "walls_lab4.yaml"


def test_the_traces_world_hash_is_of_the_file_as_compiled(tmp_path: Path) -> None:
    world = tmp_path / "room.yaml"
    world.write_bytes(WORLD.read_bytes())
    behaviour = tmp_path / "b.yaml"
    behaviour.write_text((BEHAVIOURS / "wall_follow.yaml").read_text().replace("world: walls_lab4", "world: room.yaml"))
    compiled = compile_behaviour(behaviour, {"minutes": "0.01"})
    world.write_text(WORLD.read_text() + "# changed after the compile\n")  # the file as the run would read it again
    run = compiled.bind(load_backend("pymunk"), trace=tmp_path / "t.csv", warn=lambda m: None)
    try:
        run.run()
    finally:
        run.close()
    header = read_trace(tmp_path / "t.csv").header
    assert header["world_sha256"] == hashlib.sha256(WORLD.read_bytes()).hexdigest()
    assert compiled.program.world.sha256 == header["world_sha256"]
