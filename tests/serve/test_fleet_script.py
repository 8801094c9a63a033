"""The fleet script: ``labsim scene`` adds it, the backend reads and drives the whole fleet
through it in a few round trips a tick, and the traces stay the embedded backend's."""
from __future__ import annotations

import math
from pathlib import Path

import pytest

pytest.importorskip("zmq")
pytest.importorskip("coppeliasim_zmqremoteapi_client")

from helpers import BEHAVIOURS, trace_rows

from labsim.backends.coppeliasim import fleet_script as fs
from labsim.backends.coppeliasim.replies import check_sense
from labsim.backends.protocol import BackendError
from labsim.runtime.cli.main import main

pytestmark = pytest.mark.slow  # fleet runs through labsim serve processes


def _trips(out: str) -> float:
    line = next(line for line in out.splitlines() if "round trips per tick" in line)
    return float(line.split()[0])


def test_the_wall_lab_through_the_fleet_script_in_at_most_4_round_trips(empty: int, tmp_path: Path, capsys) -> None:
    lab = BEHAVIOURS / "wall_follow.yaml"
    assert main(["scene", str(lab), "--port", str(empty)]) == 0
    assert f"the fleet script on /{fs.ALIAS}" in capsys.readouterr().out
    ref, remote = tmp_path / "ref.csv", tmp_path / "remote.csv"
    assert main(["run", str(lab), "--set", "minutes=1", "--trace", str(ref)]) == 0
    capsys.readouterr()
    assert main(["run", str(lab), "--set", "minutes=1", "--trace", str(remote),
                 "--backend", "coppeliasim", "--port", str(empty)]) == 0
    trips = _trips(capsys.readouterr().out)
    assert trace_rows(remote) == trace_rows(ref) and len(trace_rows(ref)) == 1 + 1201  # + the stopping tick
    # sense (1), the wheels that changed (0 or 1), the step (2); per object it is over 10
    assert 3.0 <= trips <= 4.0


def test_five_robots_cost_what_one_costs(empty: int, tmp_path: Path, capsys) -> None:
    lab = tmp_path / "road.yaml"
    lab.write_text((BEHAVIOURS / "road_follow.yaml").read_text().replace("seconds: 30 ", "seconds: 2"))
    assert main(["scene", str(lab), "--port", str(empty)]) == 0
    ref, remote = tmp_path / "ref.csv", tmp_path / "remote.csv"
    assert main(["run", str(lab), "-q", "--trace", str(ref)]) == 0
    capsys.readouterr()
    assert main(["run", str(lab), "--trace", str(remote), "--backend", "coppeliasim", "--port", str(empty)]) == 0
    assert _trips(capsys.readouterr().out) <= 4.25  # 4 a tick, and closing (3 requests over 40 ticks)
    assert trace_rows(remote) == trace_rows(ref) and len(trace_rows(ref)) == 1 + 5 * 40


PLAN = [[7, -2, fs.POSITION | fs.ORIENTATION, [8, 9], []]]
SONAR = [1, 0.5, [0.0, 0.0, 0.5], -1, [0.0, 0.0, 1.0]]
GOOD = [[[SONAR, SONAR], [], [1.0, 2.0, 0.1], [0.0, 0.0, 0.3], [], [0, [-1, -1]]]]

HOSTILE = [
    ("not a list", "yes", "the fleet"),
    ("two robots for one", GOOD * 2, "the fleet"),
    ("a sonar missing", [[[SONAR], [], [1.0, 2.0, 0.1], [0.0, 0.0, 0.3], [], [0, []]]], "robot 'pioneer'"),
    ("a NaN distance", [[[SONAR, [1, math.nan, [0.0, 0.0, 0.0], -1, [0.0, 0.0, 0.0]]], [], [1.0, 2.0, 0.1],
                         [0.0, 0.0, 0.3], [], [0, []]]], "robot 'pioneer'"),
    ("a position of one number", [[[SONAR, SONAR], [], [5], [0.0, 0.0, 0.3], [], [0, []]]], "robot 'pioneer'"),
    ("a collision of 'yes'", [[[SONAR, SONAR], [], [1.0, 2.0, 0.1], [0.0, 0.0, 0.3], [], "yes"]], "robot 'pioneer'"),
    ("an orientation map", [[[SONAR, SONAR], [], [1.0, 2.0, 0.1], {}, [], [0, []]]], "robot 'pioneer'"),
]


def test_a_good_sense_reply_passes_and_an_empty_lua_table_is_a_list() -> None:
    assert check_sense(GOOD, ["pioneer"], PLAN)[0][2] == [1.0, 2.0, 0.1]
    no_images = [[[SONAR, SONAR], {}, [1.0, 2.0, 0.1], [0.0, 0.0, 0.3], {}, [0, [-1, -1]]]]
    assert check_sense(no_images, ["pioneer"], PLAN)[0][1] == []


@pytest.mark.parametrize(("reply", "named"), [c[1:] for c in HOSTILE], ids=[c[0] for c in HOSTILE])
def test_a_hostile_sense_reply_names_the_function_and_the_robot(reply: object, named: str) -> None:
    with pytest.raises(BackendError) as e:
        check_sense(reply, ["pioneer"], PLAN)
    assert "sim.callScriptFunction('labsimSense')" in str(e.value) and named in str(e.value)
    assert "CoppeliaSim never sends" in str(e.value) and len(str(e.value)) < 400


def test_the_stand_in_runs_no_other_script(empty: int) -> None:
    from coppeliasim_zmqremoteapi_client import RemoteAPIClient

    client = RemoteAPIClient("127.0.0.1", empty)
    sim = client.require("sim")
    dummy = sim.createDummy(0.05)
    sim.setObjectAlias(dummy, fs.ALIAS)
    script = sim.addScript(sim.scripttype_childscript)
    sim.setScriptStringParam(script, sim.scriptstringparam_text, "print('hello')")
    sim.associateScriptWithObject(script, dummy)
    assert sim.getScript(sim.scripttype_childscript, dummy) == script
    assert sim.getObject(f"/{fs.ALIAS}", {"noError": True}) == -1  # not the fleet script: not found
    with pytest.raises(Exception, match="runs no Lua"):
        sim.callScriptFunction(fs.SENSE, script, [])
    sim.setScriptStringParam(script, sim.scriptstringparam_text, fs.LUA)
    assert sim.getObject(f"/{fs.ALIAS}") == dummy
    with pytest.raises(Exception, match="not initialized"):  # as CoppeliaSim: only while running
        sim.callScriptFunction(fs.SENSE, script, [])
    client.socket.close(0)
    client.context.term()


def test_a_served_lab_carries_the_fleet_script_and_the_crane_keeps_its_trace(tmp_path: Path, capsys) -> None:
    """``labsim serve --for`` (the student's path) serves the scene with the fleet script in it,
    as ``labsim scene`` builds it: the crane in 3 round trips a tick, the same trace."""
    from coppeliasim_zmqremoteapi_client import RemoteAPIClient

    from labsim.runtime.run import compile_behaviour
    from labsim.runtime.serve.server import Server

    lab = tmp_path / "crane.yaml"
    lab.write_text((BEHAVIOURS / "crane.yaml").read_text().replace("stop: time >= 60", "stop: time >= 5"))
    program = compile_behaviour(lab).program
    ref, remote = tmp_path / "ref.csv", tmp_path / "remote.csv"
    assert main(["run", str(lab), "-q", "--trace", str(ref)]) == 0
    with Server(program.world, 0, port=0, dt_s=program.dt_s, fleet_script=True) as server:
        assert main(["run", str(lab), "--trace", str(remote),
                     "--backend", "coppeliasim", "--port", str(server.port)]) == 0
        out = capsys.readouterr().out
        client = RemoteAPIClient("127.0.0.1", server.port)
        sim = client.require("sim")
        script = sim.getScript(sim.scripttype_childscript, sim.getObject(f"/{fs.ALIAS}"))
        with pytest.raises(Exception, match="script function does not exist"):  # no other script runs
            sim.callScriptFunction("hello", script + 1)
        client.socket.close(0)
        client.context.term()
    assert _trips(out) <= 3.2  # labsimParts (1) and the step (2); a few more to open and close
    assert trace_rows(remote) == trace_rows(ref)
