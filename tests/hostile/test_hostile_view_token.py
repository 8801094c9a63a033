"""``labsim view``'s session token: a process that can reach the port but never saw the URL.

Another user of a lab machine, or anyone on the network with ``--host 0.0.0.0``, may connect to
the port; without the token in the printed URL (or the cookie it becomes) every request, the
page, its files and the WebSocket, gets ``403`` and nothing reaches the run or the file. The
server runs in this process (as in tests/hostile/test_hostile_view.py).
"""
from __future__ import annotations

import asyncio
import json
import shutil
from collections.abc import Awaitable, Callable
from pathlib import Path

import pytest
from helpers import ROOT

from labsim.runtime.view.live import LiveSession
from labsim.runtime.view.server import REFUSED_TOKEN, bind_socket, serve

aiohttp = pytest.importorskip("aiohttp")
TOKEN = "s3cret-token-of-this-run"


def _serve(tmp_path: Path, scenario: Callable[[int, Path], Awaitable[None]], token: str | None = TOKEN) -> list[str]:
    """Run ``scenario(port, file)`` against a view of a copy of the wall lab; the server's log."""
    logs: list[str] = []
    behaviour = tmp_path / "wall_follow.yaml"
    shutil.copy(ROOT / "behaviours" / "wall_follow.yaml", behaviour)

    async def main() -> None:
        s = LiveSession(behaviour, {}, warn=lambda m: None, trace=tmp_path / "live.csv")
        assert s.load(), s.problems
        s.can_save = token is not None  # as labsim view sets it
        sock = bind_socket("127.0.0.1", 0)
        port = sock.getsockname()[1]
        task = asyncio.ensure_future(serve(s, sock, f"http://127.0.0.1:{port}/", log=logs.append, token=token))
        await asyncio.sleep(0.1)
        try:
            await scenario(port, behaviour)
        finally:
            task.cancel()
            with pytest.raises(asyncio.CancelledError):
                await task
            s.close()

    asyncio.run(main())
    return logs


async def _status(http: aiohttp.ClientSession, url: str, **kw: object) -> int:
    async with http.get(url, allow_redirects=False, **kw) as r:
        text = await r.text()
        if r.status == 403:
            assert text == REFUSED_TOKEN
        return r.status


def test_without_the_token_every_request_is_403_and_nothing_is_written(tmp_path: Path) -> None:
    before: dict[str, bytes] = {}

    async def scenario(port: int, behaviour: Path) -> None:
        before["file"] = behaviour.read_bytes()
        base = f"http://127.0.0.1:{port}"
        async with aiohttp.ClientSession() as http:
            for path in ("/", "/?chart=x", "/static/view.js", "/static/vendor/uPlot.iife.min.js", "/favicon.ico",
                         "/ws", f"/?token={TOKEN[:-1]}", f"/static/view.js?token={TOKEN}x", "/?token="):
                assert await _status(http, base + path) == 403, path
            # a cookie of the right name with another value, the right value under another port's name
            assert await _status(http, base + "/", headers={"Cookie": f"labsim_view_token_{port}=guess"}) == 403
            assert await _status(http, base + "/", headers={"Cookie": f"labsim_view_token_1={TOKEN}"}) == 403
            for url in (base + "/ws", base + "/ws?token=guess"):
                with pytest.raises(aiohttp.WSServerHandshakeError) as refused:
                    ws = await http.ws_connect(url)
                    await ws.send_str(json.dumps({"type": "save", "text": "name: owned\n"}))
                assert refused.value.status == 403
        assert behaviour.read_bytes() == before["file"]

    logs = _serve(tmp_path, scenario)
    assert logs[0] == "labsim view: refused a request from 127.0.0.1 for '/': no session token"
    assert "labsim view: refused a request from 127.0.0.1 for '/': a wrong token" in logs
    assert len(logs) == 13
    assert all(line.startswith("labsim view: refused a request from 127.0.0.1 for ") for line in logs)
    assert not (tmp_path / "live.csv").exists() or "owned" not in (tmp_path / "live.csv").read_text()


def test_the_token_becomes_a_cookie_that_opens_the_page_its_files_and_the_socket(tmp_path: Path) -> None:
    async def scenario(port: int, behaviour: Path) -> None:
        base = f"http://127.0.0.1:{port}"
        # a browser keeps a cookie of 127.0.0.1; aiohttp's jar does only when told to
        async with aiohttp.ClientSession(cookie_jar=aiohttp.CookieJar(unsafe=True)) as http:
            async with http.get(f"{base}/?token={TOKEN}&chart=swing", allow_redirects=False) as r:
                assert r.status == 302 and r.headers["Location"] == "/?chart=swing"  # out of the address bar
                cookie = r.cookies[f"labsim_view_token_{port}"]
                assert cookie.value == TOKEN and cookie["httponly"] and cookie["samesite"] == "Strict"
            assert await _status(http, base + "/?chart=swing") == 200
            assert await _status(http, base + "/static/view.js") == 200
            ws = await http.ws_connect(base + "/ws")
            assert (await ws.receive_json(timeout=10))["type"] == "scene"
            await ws.send_str(json.dumps({"type": "save", "text": "# saved by its owner\n"}))
            for _ in range(50):
                await ws.receive_json(timeout=10)
                if behaviour.read_text() == "# saved by its owner\n":
                    break
            assert behaviour.read_text() == "# saved by its owner\n"
            await ws.close()
        async with aiohttp.ClientSession() as other:  # a token in the query opens a socket too (a script)
            ws = await other.ws_connect(f"{base}/ws?token={TOKEN}")
            assert (await ws.receive_json(timeout=10))["type"] == "scene"
            await ws.close()

    assert _serve(tmp_path, scenario) == []


def test_no_token_serves_everyone_but_refuses_save(tmp_path: Path) -> None:
    async def scenario(port: int, behaviour: Path) -> None:
        before = behaviour.read_bytes()
        async with aiohttp.ClientSession() as http:
            assert await _status(http, f"http://127.0.0.1:{port}/") == 200
            ws = await http.ws_connect(f"http://127.0.0.1:{port}/ws")
            scene = await ws.receive_json(timeout=10)
            assert scene["can_save"] is False
            await ws.send_str(json.dumps({"type": "save", "text": "name: owned\n"}))
            while (msg := await ws.receive_json(timeout=10))["type"] != "error":
                pass
            assert msg["diagnostics"] == [
                f"{behaviour}: not saved: this view was started with --no-token, so any program that reaches its "
                "port could write the file; start labsim view without --no-token to save from the page"]
            await ws.close()
        assert behaviour.read_bytes() == before

    assert _serve(tmp_path, scenario, token=None) == []
