"""labsim view without a browser: the frame stream's schema, pacing in ticks, messages, the server.

Pacing is measured in simulated ticks against a clock the test drives; nothing here asserts
a wall-clock time.
"""
from __future__ import annotations

import asyncio
import itertools
import json
import math
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
from helpers import ROOT

from labsim.runtime.cli.main import main
from labsim.runtime.trace import fmt, read_trace
from labsim.runtime.view.frames import SCHEMA
from labsim.runtime.view.live import ChangeRefused, LiveSession
from labsim.runtime.view.replay import load_replay
from labsim.runtime.view.session import CHECK_EVERY, BadMessage

CRANE, ROAD, WALL = (ROOT / "behaviours" / f for f in ("crane.yaml", "road_follow.yaml", "wall_follow.yaml"))


class FakeClock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def live(path: Path, clock: FakeClock | None = None, **kw: object) -> LiveSession:
    s = LiveSession(path, {}, warn=lambda m: None, clock=clock or FakeClock(), **kw)  # type: ignore[arg-type]
    assert s.load(), s.problems
    return s


def _numbers_or_marks(values: list) -> bool:
    return all(v is None or v in ("inf", "-inf") or isinstance(v, float) for v in values)


@pytest.mark.parametrize("path", [CRANE, ROAD, WALL], ids=lambda p: p.stem)
def test_scene_and_frame_follow_the_schema(path: Path) -> None:
    s = live(path)
    scene = json.loads(json.dumps(s.scene(), allow_nan=False))
    assert scene["type"] == "scene" and scene["v"] == SCHEMA and scene["ok"] and scene["mode"] == "live"
    for key in ("name", "dt", "seed", "world", "robots", "columns", "params", "sliders", "rules", "states"):
        assert key in scene
    s.advance(5)
    frame = json.loads(json.dumps(s.frame(), allow_nan=False))
    # the tick shown is the last one run (its row in a trace), after 5 ticks run
    assert frame["type"] == "frame" and frame["v"] == SCHEMA and frame["tick"] == 4 and frame["ran"] == 5
    assert math.isclose(frame["time"], 4 * scene["dt"])
    assert len(frame["robots"]) == len(scene["robots"])
    for robot, doc in zip(frame["robots"], scene["robots"]):
        assert len(robot["values"]) == len(scene["columns"]) and _numbers_or_marks(robot["values"])
        assert len(robot["sonars"]) == len(doc["sonars"])
        if doc["model"] is not None:
            assert all(isinstance(v, float) for v in robot["pose"])
    s.close()


def test_crane_frame_has_the_mechanism_and_labels() -> None:
    s = live(CRANE)
    s.advance(3)
    frame = s.frame()
    m = frame["mechanism"]
    assert set(m["bodies"]) == {"Crab", "Upper_guide", "Gripper", "Load"}
    assert {"Arm_Actuator", "Crab_Actuator", "Hoist_Actuator"} <= set(m["joints"])
    assert frame["labels"] == {"speed": "Hoist Speed: -0.01"}  # one label, as the lab's: hoist moved last
    assert {sl["name"]: sl["label"] for sl in s.scene()["sliders"]} == dict.fromkeys(("arm", "crab", "hoist"), "speed")
    s.close()


def test_road_frame_has_the_camera_and_derived_image() -> None:
    s = live(ROAD)
    s.advance(2)
    images = s.images(3)
    assert images is not None and images["robot"] == 3
    assert images["camera"].startswith("data:image/png;base64,")
    assert [name for name, _ in images["derived"]] == ["lane"]
    assert s.images(99) is None
    s.close()


@pytest.mark.parametrize("speed", [1.0, 2.0, 5.0, 10.0])
def test_simulated_time_follows_the_speed(speed: float) -> None:
    clock = FakeClock()
    s = live(WALL, clock)
    s.handle({"type": "speed", "value": speed})
    s.handle({"type": "play"})
    for _ in range(90):  # three seconds of frames on the test's clock
        clock.now += 1 / 30
        s.catch_up()
    assert s.tick == round(3.0 * speed / s.dt_s)
    s.handle({"type": "pause"})
    clock.now += 5
    assert s.catch_up() == 0 and s.tick == round(3.0 * speed / s.dt_s)
    s.close()


def test_as_fast_as_it_goes_runs_for_most_of_a_frame_then_yields() -> None:
    clock = FakeClock()
    s = live(WALL, clock)
    s.handle({"type": "speed", "value": "max"})
    s.handle({"type": "play"})
    ticking = s.advance

    def advance(n: int) -> int:  # every tick "takes" 1 ms of the test's clock
        clock.now += n * 0.001
        return ticking(n)
    s.advance = advance  # type: ignore[method-assign]
    ran = s.catch_up(budget_s=0.025)
    assert 25 <= ran <= 25 + CHECK_EVERY  # the clock is looked at every CHECK_EVERY ticks at first
    ran = s.catch_up(budget_s=0.025)
    assert 25 <= ran <= 27  # then about every CHECK_S: slow ticks overrun a frame's budget by little
    s.close()


def test_step_pause_and_the_end_of_a_run(write) -> None:  # type: ignore[no-untyped-def]
    s = live(WALL)
    s.handle({"type": "step"})
    s.handle({"type": "step"})
    assert s.tick == 2 and not s.playing
    short = write(WALL.read_text().replace("minutes: 25", "minutes: 0.01"), "short.yaml")
    s2 = live(short)
    s2.handle({"type": "speed", "value": "max"})
    s2.handle({"type": "play"})
    s2.catch_up()
    assert s2.finished and not s2.playing and s2.tick == 12
    s.close()
    s2.close()


def test_slider_messages_reach_the_run() -> None:
    s = live(CRANE, timeline=False)
    s.advance(5)  # ticks with no move to apply: the move below must still land on the next tick
    s.handle({"type": "slider", "name": "arm", "value": 5})
    s.advance(20)  # one second of simulated time
    frame = s.frame()
    assert frame["labels"]["speed"] == "Arm Speed: 0.10"
    assert frame["sliders"]["arm"] == 5
    mode, value = frame["mechanism"]["targets"]["Arm_Actuator"]
    assert mode == "velocity" and math.isclose(value, 5.0)  # the slider's value: the script's setJointTargetVelocity
    s.close()


def test_a_slider_move_is_clamped_to_its_range() -> None:
    s = live(CRANE, timeline=False)
    s.handle({"type": "slider", "name": "crab", "value": 1e9})
    s.advance(1)
    assert s.frame()["sliders"]["crab"] == 10
    s.close()


@pytest.mark.parametrize("msg", [
    None, 3, "play", [], {"type": "nope"}, {"type": "speed", "value": -1}, {"type": "speed", "value": "fast"},
    {"type": "speed", "value": float("nan")}, {"type": "slider", "name": "boom", "value": 1},
    {"type": "slider", "name": "arm", "value": "1"}, {"type": "slider", "name": "arm", "value": True},
    {"type": "slider", "name": ["arm"], "value": 1}, {"type": "slider", "name": "x" * 5000, "value": 1},
    {"type": "params", "values": [1]}, {"type": "params", "values": {"kp": {"a": 1}}},
    {"type": "timeline", "on": "yes"}, {"type": "seek", "tick": 3},
])
def test_bad_messages_are_refused_and_the_run_goes_on(msg: object) -> None:
    s = live(CRANE)
    with pytest.raises(BadMessage):
        s.handle(msg)
    assert s.advance(3) == 3
    s.close()


def test_a_parameter_change_restarts_with_set_semantics() -> None:
    s = live(WALL)
    s.advance(10)
    assert s.handle({"type": "params", "values": {"front": "1.0"}})
    assert s.tick == 0 and s.scene()["params"]["front"] == 1.0 and s.overrides == {"front": "1.0"}
    with pytest.raises(ChangeRefused) as refused:
        s.handle({"type": "params", "values": {"frnt": "2"}})
    assert refused.value.diagnostics[0].startswith("Parameters, frnt = 2: error: unknown parameter 'frnt'")
    with pytest.raises(ChangeRefused) as refused:  # worded as the page's panel, not as --set
        s.handle({"type": "params", "values": {"front": "abc"}})
    assert refused.value.diagnostics == ["Parameters, front = abc: error: parameter 'front' is a number, not 'abc'"]
    assert s.run is not None and s.advance(2) == 2  # the old run goes on
    s.close()


@pytest.mark.slow
def test_a_live_trace_with_slider_moves_replays_row_for_row(tmp_path: Path, capsys) -> None:  # type: ignore[no-untyped-def]
    live_trace, replayed = tmp_path / "live.csv", tmp_path / "replayed.csv"
    s = live(CRANE, trace=live_trace)
    s.advance(30)
    s.handle({"type": "slider", "name": "arm", "value": 5})
    s.advance(45)
    s.handle({"type": "slider", "name": "crab", "value": -4.5})
    s.handle({"type": "slider", "name": "hoist", "value": 3})
    s.advance(60)
    s.close()
    assert main(["run", str(CRANE), "--replay", str(live_trace), "--trace", str(replayed), "-q"]) == 0
    a, b = read_trace(live_trace), read_trace(replayed)
    assert a.columns == b.columns
    assert b.rows[:len(a.rows)] == a.rows
    events = ";".join(a.column("events"))
    assert "arm=5" in events and "crab=-4.5" in events


def test_replay_session_scrubs_to_a_tick(tmp_path: Path) -> None:
    trace = tmp_path / "wall.csv"
    assert main(["run", str(WALL), "--set", "minutes=0.5", "--trace", str(trace), "-q"]) == 0
    rows = read_trace(trace)
    s = load_replay(trace, clock=FakeClock())
    scene = s.scene()
    assert scene["mode"] == "replay" and scene["ticks"] == len(rows.rows)
    s.handle({"type": "seek", "tick": 250})
    frame = s.frame()
    row = rows.rows[250]
    x, y = float(row[rows.columns.index("x")]), float(row[rows.columns.index("y")])
    assert frame["tick"] == 250 and frame["robots"][0]["pose"][:2] == [x, y]
    with pytest.raises(BadMessage):
        s.handle({"type": "slider", "name": "arm", "value": 1})
    s.handle({"type": "seek", "tick": 10 ** 9})
    assert s.tick == len(rows.rows) - 1


# -- the server, over a real socket ---------------------------------------------------------

def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def test_server_two_pages_share_the_run_and_survive_garbage() -> None:
    aiohttp = pytest.importorskip("aiohttp")
    from labsim.runtime.view.server import bind_socket, serve

    async def scenario() -> None:
        s = live(CRANE, timeline=False)
        s.clock = time.perf_counter
        logs: list[str] = []
        sock = bind_socket("127.0.0.1", 0)
        url = f"http://127.0.0.1:{sock.getsockname()[1]}"
        task = asyncio.ensure_future(serve(s, sock, url, log=logs.append))
        async with aiohttp.ClientSession() as http:
            for _ in range(100):
                try:
                    async with http.get(url + "/") as r:
                        assert r.status == 200 and "labsim view" in await r.text()
                        break
                except aiohttp.ClientConnectorError:
                    await asyncio.sleep(0.02)
            a = await http.ws_connect(url + "/ws")
            b = await http.ws_connect(url + "/ws")
            for ws in (a, b):
                assert (await ws.receive_json())["type"] == "scene"
                assert (await ws.receive_json())["type"] == "history"  # the run so far, before any frame
                assert (await ws.receive_json())["type"] == "frame"
            await a.send_str("{not json")
            await a.send_bytes(b"\x00\x01")
            await a.send_str(json.dumps({"type": "slider", "name": "arm", "value": "DROP TABLE"}))
            await a.send_str("[" * 60000)  # deep, within the size limit
            await b.send_str(json.dumps({"type": "slider", "name": "arm", "value": 5}))
            await b.send_str(json.dumps({"type": "step"}))
            labels = None
            for _ in range(50):
                msg = await a.receive_json(timeout=5)
                if msg["type"] == "frame" and msg["ran"] >= 1:
                    labels = msg["labels"]
                    break
            assert labels == {"speed": "Arm Speed: 0.10"}
            await b.close()  # a closed tab: the other one goes on
            await a.send_str(json.dumps({"type": "step"}))
            for _ in range(50):
                msg = await a.receive_json(timeout=5)
                if msg["type"] == "frame" and msg["ran"] >= 2:
                    break
            assert msg["ran"] == 2 and msg["tick"] == 1
            await a.close()
        assert sum("ignored a message" in line for line in logs) == 4
        task.cancel()
        with pytest.raises(asyncio.CancelledError):
            await task
        s.close()

    asyncio.run(scenario())


def test_a_foreign_origin_is_refused() -> None:
    aiohttp = pytest.importorskip("aiohttp")
    from labsim.runtime.view.server import bind_socket, serve

    async def scenario() -> None:
        s = live(WALL)
        sock = bind_socket("127.0.0.1", 0)
        url = f"http://127.0.0.1:{sock.getsockname()[1]}"
        task = asyncio.ensure_future(serve(s, sock, url, log=lambda m: None))
        await asyncio.sleep(0.1)
        async with aiohttp.ClientSession() as http:
            with pytest.raises(aiohttp.WSServerHandshakeError):
                await http.ws_connect(url + "/ws", headers={"Origin": "http://evil.example"})
        task.cancel()
        s.close()

    asyncio.run(scenario())


# -- the command line ----------------------------------------------------------------------

def _start(args: list[str]) -> tuple[subprocess.Popen, str]:
    p = subprocess.Popen([sys.executable, "-m", "labsim", "view", *args, "--no-browser"],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT)
    assert p.stdout is not None
    line = p.stdout.readline()
    return p, line


def test_port_in_use_is_a_clear_error(capsys) -> None:  # type: ignore[no-untyped-def]
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen(1)
        port = taken.getsockname()[1]
        code = main(["view", str(WALL), "--port", str(port), "--no-browser"])
    assert code == 2
    err = capsys.readouterr().err
    assert f"port {port} on 127.0.0.1 is in use" in err and "Traceback" not in err


def test_bad_options_are_clear_errors(capsys, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    assert main(["view", str(tmp_path / "missing.yaml"), "--no-browser"]) == 2
    with pytest.raises(SystemExit) as stop:  # argparse's own check of the port's range
        main(["view", str(WALL), "--port", "70000", "--no-browser"])
    assert stop.value.code == 2
    assert main(["view", str(WALL), "--seed", "-1", "--port", "0", "--no-browser"]) == 2
    err = capsys.readouterr().err
    assert "no such file" in err and "--seed" in err
    assert "argument --port: a port is from 0 to 65535, not 70000" in err


@pytest.mark.slow
def test_ctrl_c_stops_cleanly_and_keeps_the_trace(tmp_path: Path) -> None:
    import signal

    trace = tmp_path / "live.csv"
    p, line = _start([str(WALL), "--port", "0", "--trace", str(trace)])
    assert "http://127.0.0.1:" in line
    p.send_signal(signal.SIGINT)
    out, err = p.communicate(timeout=20)
    assert p.returncode == 130, err
    assert "Traceback" not in err and trace.exists()
    assert read_trace(trace).header["name"] == "Wall following with sonars"


@pytest.mark.slow
def test_a_behaviour_with_errors_shows_its_diagnostics_and_exits_2() -> None:
    import signal
    import urllib.request

    bad = ROOT / "tests" / "fixtures" / "unknown_sensor_with_error.yaml"
    p, line = _start([str(bad), "--port", "0"])
    url = line.split(" at ")[1].split()[0]
    # the token in the URL becomes a cookie: the redirect to the page carries it
    opener = urllib.request.build_opener(urllib.request.HTTPCookieProcessor())
    assert opener.open(url).status == 200  # the page is served, and shows them
    s = LiveSession(bad, {}, warn=lambda m: None)
    assert not s.load() and not s.scene()["ok"]
    p.send_signal(signal.SIGINT)
    out, err = p.communicate(timeout=20)
    assert p.returncode == 2
    check = subprocess.run([sys.executable, "-m", "labsim", "check", str(bad)],
                           capture_output=True, text=True, cwd=ROOT)
    assert check.stderr and check.stderr in err
    assert "\n".join(s.scene()["diagnostics"]) in check.stderr


@pytest.mark.slow
def test_a_live_view_through_labsim_serve_sees_the_embedded_run(tmp_path: Path) -> None:
    # --backend coppeliasim: the page's run goes through the ZMQ remote API (here to the
    # stand-in server for the behaviour's scene) and shows what the embedded run shows
    from labsim.runtime.run import compile_behaviour
    from labsim.runtime.serve.server import Server

    program = compile_behaviour(WALL).program
    with Server(program.world, 1, port=0) as srv:
        remote = live(WALL, backend="coppeliasim", backend_options={"port": srv.port})
        embedded = live(WALL)
        assert remote.advance(40) == embedded.advance(40) == 40
        a, b = remote.frame(), embedded.frame()
        remote.close()
        embedded.close()
    assert a["tick"] == b["tick"] == 39 and a["ran"] == b["ran"] == 40
    assert a["robots"] == b["robots"]


def test_simulator_address_options_go_with_coppeliasim_only(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["view", str(WALL), "--sim-port", "23000", "--no-browser"]) == 2
    assert "--sim-port: error: only --backend coppeliasim takes --sim-port" in capsys.readouterr().err
    with pytest.raises(SystemExit) as stop:  # argparse's own check of the option's range
        main(["view", str(WALL), "--backend", "coppeliasim", "--sim-timeout", "0", "--no-browser"])
    assert stop.value.code == 2
    assert "argument --sim-timeout: give from 0.01 to 3600 seconds, not 0" in capsys.readouterr().err


class _Socket:
    """A page's socket that keeps what it is sent."""

    def __init__(self) -> None:
        self.sent: list[dict] = []

    async def send_str(self, text: str) -> None:
        self.sent.append(json.loads(text))


def test_the_end_reaches_the_page_when_the_last_tick_went_out_with_the_frame_before(write) -> None:  # type: ignore[no-untyped-def]
    from labsim.runtime.view.server import Page, ViewServer

    short = write(WALL.read_text().replace("minutes: 25", "minutes: 0.01"), "short.yaml")
    s = live(short)
    s.clock = time.perf_counter
    s.handle({"type": "speed", "value": "max"})
    s.advance(12)  # the last tick that runs: the next one sees the stop and runs nothing
    assert not s.finished
    s.handle({"type": "play"})
    server = ViewServer(s, log=lambda m: None)
    page = _Socket()
    server.pages.append(Page(page, "test"))  # type: ignore[arg-type]
    server.dirty = False

    async def scenario() -> None:
        task = asyncio.ensure_future(server.pace())
        for _ in range(100):
            await asyncio.sleep(0.02)
            if page.sent and page.sent[-1]["finished"]:
                break
        task.cancel()
    asyncio.run(scenario())
    assert page.sent and page.sent[-1]["finished"] and not page.sent[-1]["playing"]
    s.close()


def _off_segment(p: tuple[float, float], a: tuple[float, float], b: tuple[float, float]) -> float:
    ax, ay, bx, by = *a, *b
    vx, vy = bx - ax, by - ay
    t = max(0.0, min(1.0, ((p[0] - ax) * vx + (p[1] - ay) * vy) / ((vx * vx + vy * vy) or 1.0)))
    return math.hypot(p[0] - ax - t * vx, p[1] - ay - t * vy)


def test_a_thinned_path_keeps_its_corners_and_stays_within_the_tolerance() -> None:
    from labsim.runtime.view.record import PathThinner

    # a square's three sides then a circle's arc, a point every 2 mm
    points = [(k * 0.002, 0.0) for k in range(500)] + [(1.0, k * 0.002) for k in range(500)]
    points += [(1.0 - k * 0.002, 1.0) for k in range(500)]
    points += [(0.5 * math.cos(k / 200), 1.5 + 0.5 * math.sin(k / 200)) for k in range(600)]
    thin = PathThinner(0.005)
    for x, y in points:
        thin.add(x, y)
    kept = thin.take() + [points[-1]]  # the frame's pose ends what was kept
    assert len(kept) < len(points) / 10
    assert any(math.hypot(x - 1.0, y) <= 0.007 for x, y in kept)  # the corner at (1, 0), within the tolerance
    assert any(math.hypot(x - 1.0, y - 1.0) <= 0.007 for x, y in kept)
    worst = max(min(_off_segment(p, a, b) for a, b in itertools.pairwise(kept)) for p in points)
    assert worst <= 0.0105  # within about twice the tolerance of the drawn line, everywhere
    assert thin.take() == []
    for k in range(10):  # on a line, then put elsewhere by hand: the path lifts the pen, then goes on
        thin.add(k * 0.01, 0.0)
    thin.jump(5.0, 5.0)
    for k in range(1, 10):
        thin.add(5.0, 5.0 + k * 0.01)
    after = thin.take()
    gap = next(i for i, (x, _) in enumerate(after) if math.isnan(x))
    assert after[gap + 1] == (5.0, 5.0) and all(math.isfinite(x) for x, _ in after[gap + 1:])


def test_the_generated_tick_hook_keeps_what_the_general_one_keeps() -> None:
    # a breakpoint that never holds sends every tick the general way: both pages must be the same
    # (a front threshold of 5 cm: the robot bumps into walls, hundreds of collisions begun and ended)
    sessions = [LiveSession(WALL, {"front": "0.05"}, warn=lambda m: None, clock=FakeClock(), breaks=b)
                for b in ([], ["time:100000"])]
    assert all(s.load() and "after_act" in vars(s.recorder) for s in sessions)
    fast, general = sessions
    for _ in range(10):
        a, b = fast.advance(1009), general.advance(1009)
        assert a == b
        fa, fb = fast.frame(), general.frame()
        assert fa["robots"] == fb["robots"] and fa["events"] == fb["events"]
    assert fast.recorder.collisions[0] > 0  # the wall lab bumps: collisions were seen both ways
    fast.close()
    general.close()


def test_timeline_moves_inside_a_stretch_of_ticks_land_on_their_tick(tmp_path: Path) -> None:
    # stretches of 37 ticks: the crane's moves at 6, 8 and 14 s (ticks 120, 160, 280) fall inside
    # them, where the view ticks with the inputs' hook; between moves it ticks without
    viewed, ran = tmp_path / "view.csv", tmp_path / "run.csv"
    s = live(CRANE, trace=viewed)
    while s.tick < 330:
        s.advance(37)
    s.close()
    assert main(["run", str(CRANE), "--trace", str(ran), "-q"]) == 0
    a, b = read_trace(viewed), read_trace(ran)
    assert a.columns == b.columns and len(a.rows) >= 330
    assert a.rows[:330] == b.rows[:330]
    events = ";".join(a.column("events"))
    assert "arm=0.1" in events and "crab=0.6" in events


def test_kept_chart_values_pack_and_thin_as_the_python_ones() -> None:
    import struct

    from labsim.runtime.view.peaks import Kept, packed
    pack = struct.Struct("3d").pack
    as_list, as_doubles = Kept(5, 3), Kept(5, 3, packed=True)
    for t in range(101):
        row = (float(t), t % 2 == 0, None if t == 50 else -t)
        as_list.values.extend(row)
        as_doubles.data += packed(pack, row)  # type: ignore[operator]
    for k in (as_list, as_doubles):
        k.thin()
    numbers = as_doubles.numbers()
    assert numbers is not None and len(as_doubles) == len(as_list) == 51
    assert as_doubles.tick_list() == as_list.tick_list() == [*range(5, 105, 2), 105]
    assert numbers[25].tolist()[:2] == [50.0, 1.0] and math.isnan(numbers[25][2])
    assert numbers[-1].tolist() == [100.0, 1.0, -100.0] and len(as_doubles.drop_last()) == 50
    assert packed(pack, (10 ** 400, "a", -(10 ** 400))) == pack(math.inf, math.nan, -math.inf)


@pytest.mark.parametrize("path", [CRANE, ROAD, WALL, ROOT / "behaviours" / "line_follow.yaml"], ids=lambda p: p.stem)
def test_every_frame_of_every_lab_stays_under_4_kb(path: Path) -> None:
    # from a few ticks a frame (a set speed) to hundreds (as fast as it goes); the road lab's five
    # robots, each with its chart rows and metrics, are the largest
    for stride in (1, 6, 37, 150):
        s = live(path)
        for _ in range(min(60, 3000 // stride)):
            if not s.advance(stride):
                break
            size = len(json.dumps(s.frame(), separators=(",", ":"), allow_nan=False))
            assert size < 4096, (stride, s.tick, size)
        s.close()


def test_a_live_run_its_stop_condition_ended_has_the_footer_labsim_run_writes(tmp_path: Path) -> None:
    viewed, ran = tmp_path / "view.csv", tmp_path / "run.csv"
    s = LiveSession(WALL, {"minutes": "0.5"}, warn=lambda m: None, clock=FakeClock(), trace=viewed)
    assert s.load()
    while s.advance(500):
        pass
    s.close()  # the server stopping after the end
    assert main(["run", str(WALL), "--set", "minutes=0.5", "--trace", str(ran), "-q"]) == 0
    assert viewed.read_text().splitlines()[-1] == ran.read_text().splitlines()[-1]
    assert '"interrupted": false' in viewed.read_text().splitlines()[-1]


@pytest.mark.parametrize("path", [WALL, ROAD, ROOT / "behaviours" / "line_follow.yaml"], ids=lambda p: p.stem)
def test_the_last_frame_shows_the_last_tick_that_acted_with_its_own_signals(path: Path, tmp_path: Path) -> None:
    # the stop condition is read from the stopping tick's signals, which no rule acts on: the last
    # frame names the tick before and must show that tick's signals, as the trace's row has them
    trace = tmp_path / "t.csv"
    s = LiveSession(path, {"minutes": "0.3"} if path != ROAD else {}, warn=lambda m: None, clock=FakeClock(),
                    trace=trace)
    assert s.load()
    while s.advance(97):
        pass
    frame, scene = s.frame(), s.scene()
    columns, names = [c["name"] for c in scene["columns"]], [r["name"] for r in scene["robots"]]
    s.close()
    rows = read_trace(trace)
    checked = 0
    for k, robot in enumerate(frame["robots"]):
        row = next(r for r in rows.rows if int(r[rows.columns.index("tick")]) == frame["tick"]
                   and ("robot" not in rows.columns or r[rows.columns.index("robot")] == names[k]))
        for name, value in zip(columns, robot["values"]):
            checked += name in rows.columns and isinstance(value, float)
            if name in rows.columns and isinstance(value, float):
                assert fmt(value) == row[rows.columns.index(name)], (name, frame["tick"])
    assert checked > 5 and frame["finished"]


def test_frames_carry_the_path_and_chart_samples_of_the_ticks_between_them() -> None:
    s = live(WALL)
    sizes = []
    for _ in range(40):
        s.advance(150)  # about what runs between two frames at "as fast as it goes"
        frame = s.frame()
        sizes.append(len(json.dumps(frame, separators=(",", ":"), allow_nan=False)))
    robot = frame["robots"][0]
    assert robot["path"] and all(len(p) == 2 for p in robot["path"])
    columns = len(s.scene()["columns"])
    assert 1 < len(robot["samples"]) <= 150 and all(len(r) == columns + 1 for r in robot["samples"])
    times = [r[0] for r in robot["samples"]]
    assert times == sorted(times) and times[-1] < frame["time"]
    assert sum(sizes) / len(sizes) < 4096
    s.advance(1)
    assert s.frame()["robots"][0]["samples"] == []  # one tick: the frame itself shows it
    s.close()


def test_breakpoints_pause_on_their_tick_and_step_goes_on(tmp_path: Path) -> None:
    trace = tmp_path / "wall.csv"
    assert main(["run", str(WALL), "--set", "minutes=0.4", "--trace", str(trace), "-q"]) == 0
    rows = read_trace(trace)
    state = rows.columns.index("state")
    turned = next(int(a[0]) for a, b in zip(rows.rows, rows.rows[1:]) if a[state] != b[state])
    s = live(WALL, breaks=["state:follow"])
    s.handle({"type": "speed", "value": "max"})
    s.handle({"type": "play"})
    s.catch_up(budget_s=1e9)
    hit = s.frame()["hit"]
    entered = turned + 1  # the first tick run in the new state
    assert hit["tick"] == entered and hit["state"] == rows.rows[entered][state] == "follow" and not s.playing
    assert s.frame()["robots"][0]["state"] == "follow"  # and the page shows it
    assert s.tick == entered + 1
    s.handle({"type": "step"})
    assert s.tick == entered + 2 and s.frame()["hit"] is None
    s.handle({"type": "break", "add": "time:20"})
    s.handle({"type": "play"})
    s.catch_up(budget_s=1e9)
    assert s.frame()["hit"]["tick"] == 400 and s.frame()["breakpoints"] == ["state:follow", "time:20"]
    with pytest.raises(ChangeRefused, match="did you mean 'sonar5'"):
        s.handle({"type": "break", "add": "sonr5 < 0.3"})
    with pytest.raises(ChangeRefused, match="no rule 'nope'"):
        s.handle({"type": "break", "add": "rule:nope"})
    with pytest.raises(BadMessage):
        s.handle({"type": "break", "remove": 7})
    s.handle({"type": "break", "remove": 0})
    assert s.frame()["breakpoints"] == ["time:20"]
    s.close()


def test_two_breakpoints_on_one_tick_are_both_named_and_neither_is_late(tmp_path: Path) -> None:
    trace = tmp_path / "wall.csv"
    assert main(["run", str(WALL), "--set", "minutes=0.4", "--trace", str(trace), "-q"]) == 0
    rows = read_trace(trace)
    state = rows.columns.index("state")
    entered = 1 + next(int(a[0]) for a, b in zip(rows.rows, rows.rows[1:]) if a[state] != b[state])
    at = f"time:{entered * 0.05:.2f}"
    # a condition listed first, true from the same tick: before, it hid the state breakpoint
    s = live(WALL, breaks=[at, "state:follow", "state == follow"])
    s.handle({"type": "speed", "value": "max"})
    s.handle({"type": "play"})
    s.catch_up(budget_s=1e9)
    hit = s.frame()["hit"]
    assert hit["tick"] == entered and hit["what"] == f"{at} and state:follow and state == follow"
    assert hit["fired"] == [{"robot": "pioneer", "what": [at, "state:follow", "state == follow"], "state": "follow",
                             "rule": hit["rule"]}]
    s.close()


def test_a_bad_set_on_the_command_line_is_exit_2_before_any_page(capsys) -> None:  # type: ignore[no-untyped-def]
    assert main(["view", str(ROOT / "behaviours" / "crane.yaml"), "--set", "minutes=0.5", "--no-browser",
                 "--port", "0"]) == 2
    out, err = capsys.readouterr()
    assert " at http" not in out  # no page was served
    assert "--set minutes=0.5: error: unknown parameter 'minutes'" in err


def test_a_bad_break_on_the_command_line_is_exit_2_with_its_column(capsys) -> None:  # type: ignore[no-untyped-def]
    assert main(["view", str(WALL), "--break", "sonar5 < 0.3 and sonr9 > 1", "--no-browser", "--port", "0"]) == 2
    err = capsys.readouterr().err
    assert "--break:1:18: error: unknown name 'sonr9' (did you mean 'sonar9'?)" in err
    assert main(["view", str(WALL), "--break", "prev(sonar5, 0) < 1", "--no-browser", "--port", "0"]) == 2
    assert "remembers earlier ticks" in capsys.readouterr().err


@pytest.mark.slow  # seconds: a live session, its trace and a replay of it; handed out first
def test_a_robot_put_by_hand_is_in_the_trace_and_replays_bit_for_bit(tmp_path: Path) -> None:
    live_trace, replayed = tmp_path / "live.csv", tmp_path / "replayed.csv"
    s = live(WALL, trace=live_trace)
    s.advance(40)
    with pytest.raises(ChangeRefused, match=r"was not moved to .*overlap a wall"):
        s.handle({"type": "place", "robot": 0, "x": 3.0, "y": -5.0, "heading": 0.0})
    s.handle({"type": "place", "robot": 0, "x": 1.0, "y": 1.0, "heading": 0.3})
    assert s.frame()["robots"][0]["pose"][:2] == [1.0, 1.0]
    s.advance(60)
    s.handle({"type": "place", "robot": 0, "x": -1.25, "y": 0.5, "heading": 2.0})
    s.advance(60)
    with pytest.raises(ChangeRefused, match="outside the world"):
        s.handle({"type": "place", "robot": 0, "x": 1e300, "y": 0.0, "heading": 0.0})
    for bad in ({"robot": 3, "x": 0, "y": 0, "heading": 0}, {"robot": 0, "x": "a", "y": 0, "heading": 0}):
        with pytest.raises(BadMessage):
            s.handle({"type": "place", **bad})
    s.close()
    assert main(["run", str(WALL), "--replay", str(live_trace), "--trace", str(replayed), "-q"]) == 0
    a, b = read_trace(live_trace), read_trace(replayed)
    assert b.rows[:len(a.rows)] == a.rows
    events = [e for e in a.column("events") if e.startswith("place")]
    assert events == ["place pioneer 1.0 1.0 0.3", "place pioneer -1.25 0.5 2.0"]


def test_an_edit_that_breaks_the_file_keeps_the_run_and_one_that_compiles_restarts(write) -> None:  # type: ignore[no-untyped-def]
    lab = write(WALL.read_text(), "wall.yaml")
    s = live(lab)
    scene = s.scene()
    assert scene["source"] == WALL.read_text() and not scene["edited"] and not scene["read_only"]
    s.advance(20)
    broken = scene["source"].replace("sonar5", "sonr5", 1)
    with pytest.raises(ChangeRefused) as refused:
        s.handle({"type": "apply", "text": broken})
    place = refused.value.places[0]
    line = next(i for i, text in enumerate(broken.split("\n"), 1) if "sonr5" in text)
    assert place["line"] == line and "sonr5" in place["message"] and place["col"] >= 1
    assert s.tick == 20  # the old run goes on
    fixed = scene["source"].replace("minutes: 25", "minutes: 1")
    assert s.handle({"type": "apply", "text": fixed}) is True
    assert s.tick == 0 and s.scene()["edited"] and s.scene()["source"] == fixed
    assert s.run is not None and s.run.program.stop_horizon_s == 60
    assert lab.read_text() == WALL.read_text()  # applied, not saved
    s.handle({"type": "save", "text": fixed})
    assert lab.read_text() == fixed and not s.scene()["edited"]
    assert [p.name for p in lab.parent.iterdir() if p.name.startswith(".")] == []  # no temporary left
    s.close()
    ro = live(lab, read_only=True)
    assert ro.scene()["read_only"]
    for kind in ("apply", "save"):
        with pytest.raises(ChangeRefused, match="read-only"):
            ro.handle({"type": kind, "text": "x"})
    with pytest.raises(BadMessage):
        ro.handle({"type": "apply", "text": 5})
    assert lab.read_text() == fixed
    ro.close()


def test_a_frame_shows_the_tick_the_trace_has_a_row_for(tmp_path: Path) -> None:
    """After n ticks the frame says tick n - 1, and its time, pose, state, rule and sonars are
    that row's; its chart samples are rows too, at their own ticks' times."""
    trace = tmp_path / "wall.csv"
    s = live(WALL, trace=trace)
    assert s.frame()["tick"] == 0 and s.frame()["ran"] == 0
    sonar5 = next(k for k, c in enumerate(s.scene()["columns"]) if c["name"] == "sonar5")
    frames = []
    for n in (1, 367, 1, 30):  # the wall lab goes from wander to follow on tick 368
        s.advance(n)
        frames.append(s.frame())
    s.close()
    rows = read_trace(trace)
    col = {c: rows.columns.index(c) for c in ("tick", "time", "x", "y", "state", "rule", "sonar5")}
    by_tick = {int(r[col["tick"]]): r for r in rows.rows}
    assert [f["tick"] for f in frames] == [0, 367, 368, 398] and [f["ran"] for f in frames] == [1, 368, 369, 399]
    assert {f["robots"][0]["state"] for f in frames} == {"wander", "follow"}
    for f in frames:
        row, robot = by_tick[f["tick"]], f["robots"][0]
        assert fmt(f["time"]) == row[col["time"]]
        assert [fmt(v) for v in robot["pose"][:2]] == [row[col["x"]], row[col["y"]]]
        assert robot["state"] == row[col["state"]] and (robot["rule"] or "") == row[col["rule"]]
        samples = robot["samples"]
        # more ticks than rows: least/greatest pairs, at each group's first and last tick
        pairs = len(samples) < f["ran"] - (frames[frames.index(f) - 1]["ran"] if frames.index(f) else 0) - 1
        for k, sample in enumerate(samples):
            tick = round(sample[0] / 0.05)
            assert sample[0] == round(tick * 0.05, 9) and tick < f["tick"]
            if pairs:  # the least (or greatest) of the group's ticks is one of them, recorded
                first = tick if k % 2 == 0 else round(samples[k - 1][0] / 0.05)
                last = tick if k % 2 else round(samples[k + 1][0] / 0.05)
                group = [float(by_tick[t][col["sonar5"]]) for t in range(first, last + 1)]
                finite = [v for v in group if math.isfinite(v)]  # an inf tick is a gap: passed over
                if not finite:
                    assert sample[1 + sonar5] is None
                    continue
                # a group that only fell has its greatest first (its line falls); else its least
                steps = [(a, b) for a, b in itertools.pairwise(group) if math.isfinite(a) and math.isfinite(b)]
                fell = any(b < a for a, b in steps) and not any(b > a for a, b in steps)
                want, got = ((max(finite) if fell else min(finite)) if k % 2 == 0
                             else (min(finite) if fell else max(finite))), float(sample[1 + sonar5])
                assert want == got or abs(want - got) < 1e-3
                continue
            value, recorded = sample[1 + sonar5], by_tick[tick][col["sonar5"]]
            assert value == recorded if isinstance(value, str) else abs(float(recorded) - value) < 1e-3


def test_every_message_a_page_sends_is_in_one_table_and_in_the_docs(tmp_path: Path) -> None:
    from labsim.runtime.view.session import MESSAGES

    assert len(MESSAGES) == 17 and set(MESSAGES) >= {"play", "seek", "ack", "select", "break", "block"}
    docs = (ROOT / "docs" / "view.md").read_text()
    page_to_server = " ".join(docs[docs.index("Page to server"):].split())
    for kind in MESSAGES:
        assert f'"type": "{kind}"' in page_to_server or f"`{kind}`" in page_to_server, kind
    s = live(WALL)
    for kind, (method, _) in MESSAGES.items():  # a live run has every one but seek
        assert method is None or hasattr(s, method) == (kind != "seek"), kind
    with pytest.raises(BadMessage, match="a live session takes no 'seek' messages"):
        s.handle({"type": "seek", "tick": 3})
    with pytest.raises(BadMessage, match="unknown message type 'nope'"):
        s.handle({"type": "nope"})
    s.close()
    trace = tmp_path / "wall.csv"
    assert main(["run", str(WALL), "--set", "minutes=0.05", "--trace", str(trace), "-q"]) == 0
    replay = load_replay(trace)
    with pytest.raises(BadMessage, match="a replay session takes no 'slider' messages"):
        replay.handle({"type": "slider", "name": "x", "value": 1})
    replay.handle({"type": "seek", "tick": 10})
    assert replay.tick == 10


@pytest.mark.slow
def test_the_printed_url_carries_a_token_and_no_token_warns(tmp_path: Path) -> None:
    import re
    import signal
    import urllib.error
    import urllib.request

    p, line = _start([str(WALL), "--port", "0"])
    url = line.split(" at ")[1].split()[0]
    assert re.fullmatch(r"http://127\.0\.0\.1:\d+/\?token=[A-Za-z0-9_-]{32}", url), url
    with pytest.raises(urllib.error.HTTPError) as refused:
        urllib.request.urlopen(url.split("?")[0])
    assert refused.value.code == 403
    opener = urllib.request.build_opener(urllib.request.HTTPCookieProcessor())
    assert opener.open(url).status == 200 and opener.open(url.split("?")[0] + "static/view.js").status == 200
    p.send_signal(signal.SIGTERM)
    _, err = p.communicate(timeout=20)
    assert p.returncode == 143 and err.endswith("labsim view: stopped (SIGTERM)\n"), err

    p, line = _start([str(WALL), "--port", "0", "--no-token"])
    url = line.split(" at ")[1].split()[0]
    assert "token" not in url and urllib.request.urlopen(url).status == 200
    p.send_signal(signal.SIGHUP)
    _, err = p.communicate(timeout=20)
    port = url.rsplit(":", 1)[1].strip("/")
    assert err.split() == (f"labsim view: warning: --no-token: any program or person that can reach port {port} can "
                           "watch and steer the run without the URL; the page cannot save the file "
                           "labsim view: stopped (SIGHUP)").split(), err
    assert p.returncode == 129
