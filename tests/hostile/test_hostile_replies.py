"""The coppeliasim backend against a server that answers oddly: a clear error, never a traceback.

A proxy sits between the backend and ``labsim serve`` and, from the N-th call of one function
on, replaces that function's reply with a hostile one. Every case must end the run with exit
code 2, a message naming the function, the object and what came back, and the trace written
so far kept and readable as CSV, in bounded time.
"""
from __future__ import annotations

import csv
import math
import threading
from pathlib import Path

import pytest

cbor2 = pytest.importorskip("cbor2")
zmq = pytest.importorskip("zmq")
pytest.importorskip("coppeliasim_zmqremoteapi_client")

from helpers import BEHAVIOURS, serve, stop  # noqa: E402

from labsim.runtime.cli.main import main  # noqa: E402

pytestmark = pytest.mark.slow  # labsim serve processes behind a proxy, one run each

LAB = BEHAVIOURS / "wall_follow.yaml"
NAN = math.nan

# (function, its hostile "ret", after how many good replies, what the message must name)
CASES = [
    ("sim.readProximitySensor", ["x"], 40, ("sim.readProximitySensor", "sonar", "'x'")),
    ("sim.readProximitySensor", [1, "far"], 40, ("sim.readProximitySensor", "sonar", "'far'")),
    ("sim.readProximitySensor", [1, NAN, [0.0, 0.0, NAN], -1, [0.0, 0.0, 0.0]], 40,
     ("sim.readProximitySensor", "sonar", "nan")),
    ("sim.readProximitySensor", [1, -0.5, [0.0, 0.0, 0.5], -1, [0.0, 0.0, 0.0]], 40,
     ("sim.readProximitySensor", "sonar", "-0.5")),
    ("sim.getObjectPosition", [[5]], 10, ("sim.getObjectPosition", "robot 'pioneer'", "[5]")),
    ("sim.getObjectPosition", [5], 10, ("sim.getObjectPosition", "robot 'pioneer'", "5")),
    ("sim.getObjectPosition", [[1.0, NAN, 0.1]], 10, ("sim.getObjectPosition", "robot 'pioneer'", "nan")),
    ("sim.getObjectPosition", [[1.0, 10 ** 400, 0.1]], 10,  # a CBOR bignum: too large for a float
     ("sim.getObjectPosition", "robot 'pioneer'", "too large")),
    ("sim.checkCollision", ["yes"], 10, ("sim.checkCollision", "robot 'pioneer'", "'yes'")),
    ("sim.checkCollision", [[None, None]], 10, ("sim.checkCollision", "robot 'pioneer'", "None")),
    ("sim.getObjectOrientation", [{}], 10, ("sim.getObjectOrientation", "robot 'pioneer'", "{}")),
    ("sim.getObjectOrientation", [[0.0, 0.0, math.inf]], 10,
     ("sim.getObjectOrientation", "robot 'pioneer'", "inf")),
    ("sim.getSimulationState", ["running"], 0, ("sim.getSimulationState", "'running'")),
    ("sim.getObject", ["/PioneerP3DX"], 0, ("sim.getObject", "'/PioneerP3DX'")),
]


class Proxy:
    """A REP socket that forwards every request to ``labsim serve`` and garbles one function's replies."""

    def __init__(self, upstream: int, func: str, ret: list[object], after: int) -> None:
        self.ctx = zmq.Context()
        self.front = self.ctx.socket(zmq.REP)
        self.port = self.front.bind_to_random_port("tcp://127.0.0.1")
        self.back = self.ctx.socket(zmq.REQ)
        self.back.connect(f"tcp://127.0.0.1:{upstream}")
        self.func, self.ret, self.after = func, ret, after
        self.seen = 0
        self.done = threading.Event()
        self.thread = threading.Thread(target=self._loop, daemon=True)
        self.thread.start()

    def _loop(self) -> None:
        while not self.done.is_set():
            if not self.front.poll(50):
                continue
            raw = self.front.recv()
            self.back.send(raw)
            reply = self.back.recv()
            req = cbor2.loads(raw)
            if req.get("func") == self.func:
                self.seen += 1
                if self.seen > self.after:
                    reply = cbor2.dumps({"success": True, "ret": self.ret})
            self.front.send(reply)

    def close(self) -> None:
        self.done.set()
        self.thread.join(10)
        self.front.close(0)
        self.back.close(0)
        self.ctx.term()


@pytest.fixture(scope="module")
def served():
    # a scene without the fleet script: each reply checked here is a per-object call's
    proc, port = serve("-q", "--per-object")
    yield port
    stop(proc)


@pytest.fixture(scope="module")
def crane():
    proc, port = serve("-q", "crane", "--robots", "0", "--per-object")
    yield port
    stop(proc)


@pytest.fixture(scope="module")
def built():
    """labsim serve --empty with the wall lab built by labsim scene: the fleet script's path."""
    proc, port = serve("-q", "--empty")
    assert main(["scene", str(LAB), "--port", str(port), "-q"]) == 0
    yield port
    stop(proc)


# the crane's parts, and the fleet script's replies, through the same proxy
MORE = [
    ("crane", "sim.getJointPosition", ["x"], 20, ("sim.getJointPosition", "_Actuator", "'x'")),
    ("crane", "sim.readForceSensor", [1, [0.0, 0.0, NAN], [0.0, 0.0, 0.0]], 20,
     ("sim.readForceSensor", "Force_sensor", "nan")),
    ("built", "sim.callScriptFunction", [[["x"]]], 40, ("labsimSense", "robot 'pioneer'", "'x'")),
    ("built", "sim.callScriptFunction", ["no"], 40, ("labsimSense", "the fleet", "'no'")),
]


@pytest.mark.parametrize(("where", "func", "ret", "after", "named"), MORE,
                         ids=[f"{c[0]}-{c[1].removeprefix('sim.')}-{i}" for i, c in enumerate(MORE)])
def test_a_hostile_reply_to_the_crane_or_the_fleet_script(request, tmp_path: Path, capsys, where: str, func: str,
                                                          ret: list[object], after: int,
                                                          named: tuple[str, ...]) -> None:
    proxy = Proxy(request.getfixturevalue(where), func, ret, after)
    lab = BEHAVIOURS / "crane.yaml" if where == "crane" else LAB
    trace = tmp_path / "t.csv"
    try:
        code = main(["run", str(lab), "--set", "minutes=1"][:2 if where == "crane" else 4] + [
            "--backend", "coppeliasim", "--port", str(proxy.port), "--timeout", "20", "--trace", str(trace), "-q"])
    finally:
        proxy.close()
    err = capsys.readouterr().err
    assert code == 2 and "Traceback" not in err and "CoppeliaSim never sends" in err, err
    assert f"CoppeliaSim at 127.0.0.1:{proxy.port}: " in err  # the fleet script's replies too
    for part in named:
        assert part in err, (part, err)
    rows = _rows(trace)
    assert len(rows) > 1 and all(len(r) == len(rows[0]) for r in rows)


def _rows(path: Path) -> list[list[str]]:
    lines = [line for line in path.read_text().splitlines() if not line.startswith("#")]
    return list(csv.reader(lines))


@pytest.mark.parametrize(("func", "ret", "after", "named"), CASES,
                         ids=[f"{c[0].removeprefix('sim.')}-{i}" for i, c in enumerate(CASES)])
def test_a_hostile_reply_is_a_clear_error_and_the_trace_is_kept(
        served: int, tmp_path: Path, capsys, func: str, ret: list[object], after: int,
        named: tuple[str, ...]) -> None:
    proxy = Proxy(served, func, ret, after)
    trace = tmp_path / "t.csv"
    try:
        code = main(["run", str(LAB), "--set", "minutes=1", "--backend", "coppeliasim", "--port",
                     str(proxy.port), "--timeout", "20", "--trace", str(trace), "-q"])
    finally:
        proxy.close()
    err = capsys.readouterr().err
    assert code == 2, err
    assert "Traceback" not in err and len(err) < 2000, err
    for part in named:
        assert part in err, (part, err)
    assert "CoppeliaSim never sends" in err
    if after and func != "sim.getObject":  # the run had started: the rows so far are kept
        rows = _rows(trace)
        assert len(rows) > 1 and all(len(r) == len(rows[0]) for r in rows), rows[:3]
        try:
            import pandas
        except ImportError:
            return
        frame = pandas.read_csv(trace, comment="#")
        assert len(frame) == len(rows) - 1


def test_a_long_reply_is_shortened_in_the_message() -> None:
    from labsim.backends.coppeliasim.replies import SHOWN, check
    from labsim.backends.protocol import BackendError

    with pytest.raises(BackendError) as e:
        check("sim.getVisionSensorImg", (b"\x00" * 5000, [128, 128]), "robot 'r', camera")
    assert len(str(e.value)) < SHOWN + 200 and "..." in str(e.value) and "robot 'r', camera" in str(e.value)
    good = (b"\x00" * 12, [2, 2])
    assert check("sim.getVisionSensorImg", good, "") is good
