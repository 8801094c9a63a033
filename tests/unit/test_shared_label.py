"""A label several sliders share (``label_name``, format 1.2): the slider moved last writes it."""
from __future__ import annotations

from pathlib import Path

import pytest

from labsim.backends import load_backend
from labsim.dsl.compile import compile_file
from labsim.foundation.diagnostics import LabsimError
from labsim.runtime.run import compile_behaviour
from labsim.runtime.trace import read_trace

CRANE = """labsim: {version}
world: crane
stop: time >= 1
sliders:
  arm:  {{min: -1, max: 1, value: 0.5, label: "Arm {{arm:.1f}}", label_name: speed}}
  crab: {{min: -1, max: 1, label: "Crab {{crab:.1f}}", label_name: speed}}
  hoist: {{min: -1, max: 1, label: "Hoist {{hoist:.1f}}"}}
bind:
  Crab_Actuator.velocity: crab
timeline:
  - at 0.2: crab = 0.5
  - at 0.4: arm = 0.5
  - at 0.6: arm = -0.5
  - at 0.8: crab = -1, arm = 1
"""


def test_a_format_1_file_cannot_name_a_label(write) -> None:
    with pytest.raises(LabsimError) as e:
        compile_file(write(CRANE.format(version=1)))
    assert "b.yaml:5:75: error: 'label_name' is format 1.2: start the file with 'labsim: 1.2'" in str(e.value)


def test_the_slider_moved_last_shows_its_text(write, tmp_path: Path) -> None:
    path = tmp_path / "t.csv"
    run = compile_behaviour(write(CRANE.format(version=1.2))).bind(load_backend("pymunk"), trace=path,
                                                                   warn=lambda m: None)
    summary = run.run()
    run.close()
    trace = read_trace(path)
    assert [c for c in trace.columns if c.startswith("label:")] == ["label:speed", "label:hoist"]
    speed = trace.column("label:speed")
    assert speed[0] == "Arm 0.5"  # before any move: the first slider's text
    assert speed[4] == "Crab 0.5"
    assert speed[8] == "Crab 0.5"  # arm = 0.5 again is no move: its value did not change
    assert speed[12] == "Arm -0.5"
    assert speed[16] == "Crab -1.0"  # both move on one tick: the one declared last under sliders:
    assert summary.robots["crane"].labels == {"speed": speed[-1], "hoist": "Hoist 0.0"}
