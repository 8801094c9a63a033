"""Language 1.3 member by member means the same on both backends: docs/language.md's lidar sectors
example (slices, built-ins given groups, a memory per member) traced on pymunk and through
labsim serve (CoppeliaSim's remote API, the lidar as its laser scanner's signal) gives identical rows."""
from __future__ import annotations

from pathlib import Path

import pytest
from helpers import examples, serve_and_run


@pytest.mark.slow
def test_the_lidar_sectors_example_traces_the_same_through_serve(tmp_path: Path) -> None:
    lab = tmp_path / "sectors.yaml"
    lab.write_text(examples()["lidar_sectors"])
    ref, remote = serve_and_run(tmp_path, lab, "--for", str(lab))
    assert len(ref) == 602  # the header, 600 ticks and the stopping tick
    assert remote == ref
    header = ref[0].split(",")
    veer, contacts = header.index("veer"), header.index("contacts")
    assert len({row.split(",")[veer] for row in ref[1:]}) > 50  # the sectors changed as it drove
    assert float(ref[-1].split(",")[contacts]) >= 2  # and the edge detectors saw something come near
