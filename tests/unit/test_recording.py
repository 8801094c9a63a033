"""The run recorded in memory (runtime/recording.py) holds what its trace file holds of the
poses, states, rules and events, so the feedback page's pictures are those of the trace."""
from __future__ import annotations

from pathlib import Path

import numpy as np
from helpers import BEHAVIOURS

from labsim.backends import DEFAULT, load_backend
from labsim.runtime.recording import Recording
from labsim.runtime.run import compile_behaviour
from labsim.runtime.trace import read_trace


def test_the_recording_holds_what_the_trace_holds(tmp_path: Path) -> None:
    behaviour = compile_behaviour(str(BEHAVIOURS / "wall_follow.yaml"), {"minutes": "1"}, seed=2)
    traced = behaviour.bind(load_backend(DEFAULT), trace=tmp_path / "t.csv")
    traced.run()
    traced.close()
    recording = Recording()
    run = behaviour.bind(load_backend(DEFAULT), observers=[recording])
    assert run.run().metric_values() == traced.result().metric_values()  # recording changes nothing of the run
    run.close()
    file, memory = read_trace(tmp_path / "t.csv"), recording.trace("wall_follow.yaml", run.header())
    assert len(memory.rows) == len(file.rows) == 1201  # and the stopping tick (format 1.2)
    for name in ("time", "x", "y", "heading", "collided"):
        assert np.allclose(memory.numbers[name], np.array(file.column(name), dtype=float), rtol=1e-5, atol=1e-6)
    for name in ("robot", "state", "rule", "events"):
        assert memory.column(name) == file.column(name), name
    assert memory.numbers["tick"].tolist() == [float(t) for t in file.column("tick")]
    assert float(memory.numbers["time"][-1]) == float(file.column("time")[-1])  # what the picture's title says
    # the number columns are numbers only: their cells are left empty, as ``Trace.numbers`` says
    assert set(memory.column("time")) == set(memory.column("x")) == {""}
