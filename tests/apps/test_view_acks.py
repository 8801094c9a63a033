"""labsim view's backpressure: a page that acknowledges frames gets the next one only once it
has drawn the last, and the run never waits for it.

No test here asserts a wall-clock time: "no frame came" is a wait that the run's ticks fill.
"""
from __future__ import annotations

import asyncio
import json
from typing import Any

import pytest
from helpers import ROOT

from labsim.runtime.view.live import LiveSession

WALL = ROOT / "behaviours" / "wall_follow.yaml"


async def _frame(ws: Any, timeout: float = 10) -> dict:
    while True:
        msg = await ws.receive_json(timeout=timeout)
        if msg["type"] == "frame":
            return dict(msg)


async def _connect(http: Any, url: str) -> Any:
    """The view's websocket, once its server listens (it starts beside the test)."""
    import aiohttp
    for _ in range(200):
        try:
            return await http.ws_connect(url + "/ws")
        except aiohttp.ClientConnectorError:
            await asyncio.sleep(0.02)
    raise AssertionError(f"the view at {url} never listened")


def test_a_page_that_acknowledges_gets_the_next_frame_only_after_and_the_run_goes_on() -> None:
    aiohttp = pytest.importorskip("aiohttp")
    from labsim.runtime.view.server import bind_socket, serve

    async def scenario() -> None:
        s = LiveSession(WALL, {}, warn=lambda m: None)
        assert s.load(), s.problems
        logs: list[str] = []
        sock = bind_socket("127.0.0.1", 0)
        url = f"http://127.0.0.1:{sock.getsockname()[1]}"
        task = asyncio.ensure_future(serve(s, sock, url, log=logs.append))
        async with aiohttp.ClientSession() as http:
            ws = await _connect(http, url)
            assert (await ws.receive_json())["type"] == "scene"
            await _frame(ws)
            await ws.send_str(json.dumps({"type": "speed", "value": "max"}))
            await ws.send_str(json.dumps({"type": "play"}))
            await ws.send_str(json.dumps({"type": "ack"}))
            first = await _frame(ws)
            while first["ran"] == 0:  # the frame of the speed change, before Play
                await ws.send_str(json.dumps({"type": "ack"}))
                first = await _frame(ws)
            # not acknowledged: no frame comes, however many are due (one is due every 1/20 s)
            with pytest.raises(asyncio.TimeoutError):
                await _frame(ws, timeout=0.6)
            await ws.send_str(json.dumps({"type": "ack"}))
            second = await _frame(ws)
            # the run went on meanwhile, and the frame brings the path and chart of every tick since
            assert second["ran"] > first["ran"] + 100
            robot = second["robots"][0]
            # (as least/greatest rows of groups of ticks, from the first tick after the last frame
            # to the last before this one)
            assert robot["path"] and len(robot["samples"]) >= 6
            dt = 0.05
            assert robot["samples"][0][0] == round(first["time"] + dt, 9)
            assert robot["samples"][-1][0] == round(second["time"] - dt, 9)
            await ws.close()
        assert not any("ignored" in line for line in logs), logs  # an ack is a message the server knows
        task.cancel()
        with pytest.raises(asyncio.CancelledError):
            await task
        s.close()

    asyncio.run(scenario())


def test_a_client_that_never_acknowledges_gets_every_frame_it_can_take() -> None:
    aiohttp = pytest.importorskip("aiohttp")
    from labsim.runtime.view.server import bind_socket, serve

    async def scenario() -> None:
        s = LiveSession(WALL, {}, warn=lambda m: None)
        assert s.load(), s.problems
        sock = bind_socket("127.0.0.1", 0)
        url = f"http://127.0.0.1:{sock.getsockname()[1]}"
        task = asyncio.ensure_future(serve(s, sock, url, log=lambda m: None))
        async with aiohttp.ClientSession() as http:
            ws = await _connect(http, url)
            await ws.receive_json()
            await ws.send_str(json.dumps({"type": "speed", "value": "max"}))
            await ws.send_str(json.dumps({"type": "play"}))
            ran = [(await _frame(ws))["ran"] for _ in range(6)]
            assert ran == sorted(ran) and ran[-1] > ran[0]
            await ws.close()
        task.cancel()
        with pytest.raises(asyncio.CancelledError):
            await task
        s.close()

    asyncio.run(scenario())
