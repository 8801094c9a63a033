"""The one way in, the one way out and the access policy (foundation/files.py), and the
goldens they must leave byte-identical."""
from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest
from helpers import ROOT

from labsim.foundation.diagnostics import LabsimError
from labsim.foundation.files import (
    Output,
    allowing,
    check_output,
    policy_problem,
    read_input,
    write_output,
)
from labsim.runtime.golden import record_golden
from labsim.runtime.trace import TraceFormatError, read_trace, slider_events


def message(call, *args) -> str:  # type: ignore[no-untyped-def]
    with pytest.raises(LabsimError) as e:
        call(*args)
    (d,) = e.value.diagnostics
    return f"{d.path}: {d.message}"


def test_read_input_refuses_what_is_no_regular_file(tmp_path: Path) -> None:
    os.mkfifo(tmp_path / "p")
    assert message(read_input, tmp_path / "p", "trace") == f"{tmp_path / 'p'}: is a FIFO (named pipe), not a trace file"
    assert message(read_input, "/dev/zero") == "/dev/zero: is a device, not a behaviour file"
    assert message(read_input, tmp_path) == f"{tmp_path}: is a folder, not a behaviour file"
    assert message(read_input, tmp_path / "none.yaml") == f"{tmp_path / 'none.yaml'}: no such behaviour file"
    (tmp_path / "big").write_bytes(b"x" * 2048)
    assert message(read_input, tmp_path / "big", "world", 1024).endswith("world files are limited to 1 KiB")
    assert read_input(tmp_path / "big", "world", 2048) == b"x" * 2048


def test_the_policy_keeps_a_behaviour_in_its_folder(tmp_path: Path) -> None:
    base, outside = tmp_path / "lab", tmp_path / "other"
    (base / "sub").mkdir(parents=True)
    outside.mkdir()
    (base / "sub" / "w.yaml").write_text("labsim-world: 1\n")
    (outside / "w.yaml").write_text("labsim-world: 1\n")
    (base / "in.yaml").symlink_to(base / "sub" / "w.yaml")
    (base / "out.yaml").symlink_to(outside / "w.yaml")
    assert policy_problem("sub/w.yaml", base, []) == ""
    assert policy_problem("in.yaml", base, []) == ""  # a link that stays inside
    assert policy_problem("sub/../sub/w.yaml", base, []) == ""
    assert "absolute path" in policy_problem(str(outside / "w.yaml"), base, [])
    assert "leads out" in policy_problem("../other/w.yaml", base, [])
    assert "symbolic link" in policy_problem("out.yaml", base, [])
    assert policy_problem("../other/w.yaml", base, [outside.resolve()]) == ""  # --allow-path
    with allowing(outside):
        assert policy_problem("out.yaml", base) == ""
    assert policy_problem("out.yaml", base) != ""  # only while the block ran


def test_outputs_are_never_inputs_nor_devices(tmp_path: Path) -> None:
    src = tmp_path / "b.yaml"
    src.write_text("labsim: 1\n")
    os.link(src, tmp_path / "hard.csv")
    (tmp_path / "soft.csv").symlink_to(src)
    for name in ("hard.csv", "soft.csv", "b.yaml"):
        assert "would overwrite an input" in message(check_output, tmp_path / name, [src])
    assert "is a device" in message(check_output, "/dev/full", [src])
    assert "is a folder" in message(check_output, tmp_path, [src])
    check_output(tmp_path / "new.csv", [src])  # a new file beside them is fine


def test_an_output_replaces_its_target_only_when_complete(tmp_path: Path) -> None:
    target = tmp_path / "out.json"
    target.write_text("old")
    out = Output(target)
    out.file.write(b"half")
    assert target.read_text() == "old"  # written beside it
    out.discard()
    assert target.read_text() == "old" and sorted(p.name for p in tmp_path.iterdir()) == ["out.json"]
    write_output(target, "new")
    assert target.read_text() == "new" and sorted(p.name for p in tmp_path.iterdir()) == ["out.json"]


def test_rows_are_checked_as_read(tmp_path: Path) -> None:
    t = tmp_path / "t.csv"
    t.write_text('# labsim-trace {"format": 1}\ntick,time,robot,x,y,heading,events\n'
                 "0,0,r,1,2,0,\n1,0.05,r,1,2,0,arm=5\n2,0.1,r,1,2,0,arm=fast\n")
    with pytest.raises(TraceFormatError) as e:
        slider_events(read_trace(t))
    assert str(e.value) == f"{t}:5: event 'arm=fast': a slider's value 'fast' is not a number"
    assert e.value.diagnostic(str(t)).format().startswith(f"{t}:5:1: error: event 'arm=fast'")
    t.write_text(t.read_text().replace("1,0.05,r,1", "1,0.05,r,east"))
    with pytest.raises(TraceFormatError, match=r":4: column 'x' holds 'east', not a number"):
        read_trace(t)


def test_a_golden_recorded_again_is_byte_identical(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Goldens are stored without the trace's footer: recording one again changes no byte."""
    (tmp_path / "behaviours").mkdir()
    shutil.copy(ROOT / "behaviours" / "crane.yaml", tmp_path / "behaviours" / "crane.yaml")
    monkeypatch.chdir(tmp_path)
    golden, _ = record_golden("behaviours/crane.yaml")
    assert golden.read_bytes() == (ROOT / "behaviours" / "crane.golden.csv").read_bytes()


def test_a_link_planted_as_the_partial_trace_is_not_followed(tmp_path: Path) -> None:
    victim = tmp_path / "victim.yaml"
    victim.write_text("labsim: 1\n")
    (tmp_path / "run.csv.partial").symlink_to(victim)
    out = Output(tmp_path / "run.csv", partial=tmp_path / "run.csv.partial")
    out.file.write(b"rows")
    out.commit()
    assert victim.read_text() == "labsim: 1\n" and (tmp_path / "run.csv").read_text() == "rows"


def test_trace_rows_reach_the_disk_within_a_second(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from labsim.runtime import trace as trace_module

    now = [100.0]
    monkeypatch.setattr(trace_module.time, "monotonic", lambda: now[0])
    writer = trace_module.TraceWriter(tmp_path / "t.csv", {"format": 1}, ["tick", "x"])
    partial = tmp_path / "t.csv.partial"
    writer.write([0, 1.0])
    assert partial.read_text() == ""  # buffered: a row is small
    now[0] += trace_module.FLUSH_S
    writer.write([1, 2.0])
    assert partial.read_text().splitlines()[-1] == "1,2"  # a second later, on the disk
    writer.close(2, interrupted=False)
    assert (tmp_path / "t.csv").read_text().endswith('# end {"interrupted": false, "ticks": 2}\n')
