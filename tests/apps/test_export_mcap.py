"""``labsim export TRACE -o run.mcap`` and ``labsim run --trace run.mcap``: every lab's golden
trace written as MCAP and read back with the mcap package's reader."""
from __future__ import annotations

import json
import math
import subprocess
import sys
from collections import defaultdict
from pathlib import Path

import pytest
from mcap.reader import make_reader

from labsim.runtime.export.mcap_file import export_trace, topic_names
from labsim.runtime.labs import LABS_DIR
from labsim.runtime.trace import read_trace

GOLDENS = sorted(LABS_DIR.glob("*.golden.csv"))


def _messages(path: Path) -> dict[str, list[tuple[str, int, dict]]]:
    """topic -> (schema name, log time, message) in the file's order."""
    out: dict[str, list[tuple[str, int, dict]]] = defaultdict(list)
    with path.open("rb") as f:
        for schema, channel, message in make_reader(f).iter_messages(log_time_order=False):
            assert channel.message_encoding == "json" and schema is not None and schema.encoding == "jsonschema"
            out[channel.topic].append((schema.name, message.log_time, json.loads(message.data)))
    return out


def _cell(text: str) -> float | None:
    v = float(text)
    return v if math.isfinite(v) else None


@pytest.mark.slow
@pytest.mark.parametrize("golden", GOLDENS, ids=[g.name.split(".")[0] for g in GOLDENS])
def test_each_labs_trace_reads_back_from_its_mcap(golden: Path, tmp_path: Path) -> None:
    out = tmp_path / "run.mcap"
    done = export_trace(golden, out)
    trace = read_trace(golden)
    col = {c: i for i, c in enumerate(trace.columns)}
    robots = list(dict.fromkeys(trace.column("robot")))
    assert done.robots == tuple(robots) and done.world_note == ""
    found = _messages(out)
    dt = trace.header["dt"]
    topics = topic_names(robots)
    assert sorted(t for t in found if t.endswith("/pose")) == sorted(f"/{t}/pose" for t in topics.values())
    for robot in robots:
        rows = [r for r in trace.rows if r[col["robot"]] == robot]
        poses = found[f"/{topics[robot]}/pose"]
        assert len(poses) == len(rows) == len({r[col["tick"]] for r in rows})  # a message per tick
        for (schema, at, m), r in zip(poses, rows):
            assert schema == "foxglove.PoseInFrame" and m["frame_id"] == "world"
            assert at == round(int(r[col["tick"]]) * dt * 1e9)
            assert (m["pose"]["position"]["x"], m["pose"]["position"]["y"]) == (float(r[col["x"]]), float(r[col["y"]]))
            q = m["pose"]["orientation"]
            assert math.atan2(q["z"], q["w"]) * 2 == pytest.approx(math.remainder(float(r[col["heading"]]), math.tau),
                                                                   abs=1e-12)
        rows_back = found[f"/{topics[robot]}/trace"]
        assert len(rows_back) == len(rows)
        for (_, _, m), r in zip(rows_back, rows):
            assert list(m) == trace.columns
            for c, i in col.items():
                expected = r[i] if c in ("robot", "state", "rule", "events") or c.startswith("label:") else _cell(r[i])
                assert m[c] == expected, (c, r[i])
        states = found[f"/{topics[robot]}/state"]
        assert [(m["state"], m["rule"]) for _, _, m in states] == [(r[col["state"]], r[col["rule"]]) for r in rows]
    tf = found["/tf"]
    assert {m["child_frame_id"] for _, _, m in tf} == set(robots) and len(tf) == len(trace.rows)
    events = [(r[col["robot"]], e) for r in trace.rows for e in r[col["events"]].split(";") if e]
    assert [(m["name"], m["message"]) for _, _, m in found.get("/events", [])] == events
    assert all(s == "foxglove.Log" and m["level"] == 2 for s, _, m in found.get("/events", []))
    [(schema, at, scene)] = found["/world"]
    assert schema == "foxglove.SceneUpdate" and at == 0
    [entity] = scene["entities"]
    assert entity["frame_id"] == "world" and entity["lines"]  # the bounds at least
    with out.open("rb") as f:
        metadata = {m.name: m.metadata for m in make_reader(f).iter_metadata()}
    assert json.loads(metadata["labsim"]["world"]) == trace.header["world"]


def test_the_wall_labs_walls_are_boxes_where_the_world_has_them(tmp_path: Path) -> None:
    from labsim.backends.scene.world_file import load_world
    from labsim.backends.scene.world_names import find_world
    from labsim.foundation.diagnostics import Report

    out = tmp_path / "w.mcap"
    text = (LABS_DIR / "wall_follow.golden.csv").read_text(encoding="utf-8").split("\n")
    short = tmp_path / "short.csv"
    short.write_text("\n".join(text[:12]) + "\n", encoding="utf-8")
    export_trace(short, out)
    world = load_world(find_world("walls_lab4").path, Report())
    assert world is not None
    [(_, _, scene)] = _messages(out)["/world"]
    cubes = scene["entities"][0]["cubes"]
    assert len(cubes) == len(world.walls)
    first = world.walls[0]
    assert cubes[0]["pose"]["position"]["x"] == pytest.approx((first.a[0] + first.b[0]) / 2)
    assert cubes[0]["size"]["z"] == first.height_m


def test_topic_names_are_plain_and_distinct() -> None:
    assert topic_names(["pioneer[0]", "pioneer_0", "a b", "é", "crane"]) == {
        "pioneer[0]": "pioneer_0", "pioneer_0": "pioneer_0_2", "a b": "a_b", "é": "robot", "crane": "crane"}


def _labsim(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "labsim", *args], capture_output=True, text=True, cwd=cwd,
                          check=False)


@pytest.mark.slow
def test_run_writes_its_trace_as_mcap(tmp_path: Path) -> None:
    done = _labsim("run", "wall_follow", "--set", "minutes=0.1", "-q", "--trace", "run.mcap", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.mcap"]  # the CSV it went through is gone
    found = _messages(tmp_path / "run.mcap")
    assert len(found["/pioneer/pose"]) == 121  # 6 s at 0.05 s a tick, and the tick it stopped on (format 1.2)
    csv_run = _labsim("run", "wall_follow", "--set", "minutes=0.1", "-q", "--trace", "run.csv", cwd=tmp_path)
    assert csv_run.returncode == 0
    rows = read_trace(tmp_path / "run.csv").rows
    assert [m["x"] for _, _, m in found["/pioneer/trace"]] == [float(r[3]) for r in rows]


@pytest.mark.slow
def test_export_refuses_what_plot_refuses_in_plots_words(tmp_path: Path) -> None:
    (tmp_path / "notes.txt").write_text("hello\n", encoding="utf-8")
    (tmp_path / "bad.csv").write_text("# labsim-trace {\"format\": 1}\ntick,time,robot,x,y,heading\n"
                                      "0,0,r,1,2,0\nx1,0,r,1,2,0\n", encoding="utf-8")
    (tmp_path / "empty.csv").write_text("# labsim-trace {\"format\": 1}\ntick,time,robot,x,y,heading\n",
                                        encoding="utf-8")
    for given in (str(LABS_DIR / "wall_follow.yaml"), "notes.txt", "bad.csv", "empty.csv", "missing.csv"):
        plot = _labsim("plot", given, "-o", "p.png", cwd=tmp_path)
        export = _labsim("export", given, "-o", "e.mcap", cwd=tmp_path)
        assert export.returncode == plot.returncode == 2
        assert export.stderr == plot.stderr and export.stderr.count("error:") == 1
    assert not (tmp_path / "e.mcap").exists()
    wrong = _labsim("export", str(LABS_DIR / "crane.golden.csv"), "-o", "e.csv", cwd=tmp_path)
    assert wrong.returncode == 2
    assert wrong.stderr == "e.csv: error: '.csv' is not a kind of file labsim export writes; use .mcap\n"
