"""Hostile requests to ``labsim view``'s page server, each with the answer and the log it must give.

A web page from another site reaching the server under a name of its own (DNS rebinding), a
5,000-digit integer in a message, a 200 KB header, 300 connections each sending garbage, a
server listening beyond loopback, and a replayed trace of more columns than a page can hold.
The server runs in this process (as in tests/apps/test_view.py); requests are written on raw
sockets where the Host header matters, since an HTTP client writes its own.
"""
from __future__ import annotations

import asyncio
import json
import subprocess
import sys
import time
from pathlib import Path

import pytest
from helpers import COLUMNS, ROOT, header

from labsim.runtime.cli.main import main
from labsim.runtime.trace import TraceWriter
from labsim.runtime.view.guard import LOG_LIMIT, REFUSED_HOST, LogBudget, exposure_warning, host_allowed
from labsim.runtime.view.live import LiveSession
from labsim.runtime.view.replay import MAX_COLUMNS

aiohttp = pytest.importorskip("aiohttp")
WALL = ROOT / "behaviours" / "wall_follow.yaml"
TOO_LARGE = "number too large: labsim's numbers are 64-bit floats, at most about 1.8e+308"


@pytest.mark.parametrize(("host", "listen", "allowed"), [
    ("127.0.0.1:8765", "127.0.0.1", True),
    ("localhost:8765", "127.0.0.1", True),
    ("LOCALHOST", "127.0.0.1", True),
    ("[::1]:8765", "127.0.0.1", True),
    ("127.0.0.2:8765", "127.0.0.1", True),  # all of 127/8 is this machine
    ("evil.example:8765", "127.0.0.1", False),  # a name the attacker's DNS points at 127.0.0.1
    ("evil.example", "0.0.0.0", False),  # names are refused even on every address
    ("localhost.evil.example", "127.0.0.1", False),
    ("192.168.1.5:8765", "127.0.0.1", False),
    ("192.168.1.5:8765", "0.0.0.0", True),  # an address in digits cannot be rebound
    ("[fe80::1]:8765", "::", True),
    ("lab-pc.local:8765", "lab-pc.local", True),  # the name --host gave
    ("LAB-PC.local.", "lab-pc.local", True),
    ("other-pc.local", "lab-pc.local", False),
    ("10.0.0.7:8765", "10.0.0.7", True),
    ("", "127.0.0.1", False),
    (None, "127.0.0.1", False),
])
def test_the_host_header_names_this_server(host: str | None, listen: str, allowed: bool) -> None:
    assert host_allowed(host, listen) is allowed


def test_listening_beyond_loopback_is_a_warning() -> None:
    assert exposure_warning("127.0.0.1", "127.0.0.1", 8765) is None
    assert exposure_warning("localhost", "::1", 8765) is None
    assert exposure_warning("0.0.0.0", "0.0.0.0", 8765) == (
        "labsim view: warning: listening on every address of this machine, port 8765: anyone who can reach "
        "it can watch and steer the run; leave out --host to keep it on this machine")
    assert exposure_warning("10.0.0.7", "10.0.0.7", 80) == (
        "labsim view: warning: listening on 10.0.0.7 (10.0.0.7), port 80: anyone who can reach it can watch "
        "and steer the run; leave out --host to keep it on this machine")


def test_the_log_budget_is_the_servers_not_a_connections() -> None:
    lines: list[str] = []
    budget = LogBudget(lines.append)
    for k in range(12_001):
        budget(f"line {k + 1}")
    assert len(lines) == LOG_LIMIT + 3
    assert lines[LOG_LIMIT:] == [
        f"line {n} (the server's log line {n}: past 20, only lines 100, 1000, ... are shown)"
        for n in (100, 1000, 10000)]


# -- the server, in this process --------------------------------------------------------------

def _raw(port: int, request: bytes) -> bytes:
    """What the server answers to the bytes of one request: to the end of its body, or of the
    connection (a refused upgrade keeps it open)."""
    import re
    import socket

    with socket.create_connection(("127.0.0.1", port), timeout=10) as s:
        s.sendall(request)
        out = b""
        while chunk := s.recv(65536):
            out += chunk
            head, blank, body = out.partition(b"\r\n\r\n")
            length = re.search(rb"(?i)content-length: *(\d+)", head)
            if blank and length and len(body) >= int(length.group(1)):
                break
    return out


def _get(port: int, host: str | None, extra: bytes = b"") -> bytes:
    line = b"" if host is None else b"Host: " + host.encode() + b"\r\n"
    return _raw(port, b"GET / HTTP/1.1\r\n" + line + extra + b"Connection: close\r\n\r\n")


def _serve(scenario) -> list[str]:  # type: ignore[no-untyped-def]
    """Run ``scenario(port)`` against a view server of the wall lab; the lines the server logged."""
    from labsim.runtime.view.server import bind_socket, serve

    logs: list[str] = []

    async def main() -> None:
        s = LiveSession(WALL, {}, warn=lambda m: None)
        assert s.load(), s.problems
        sock = bind_socket("127.0.0.1", 0)
        port = sock.getsockname()[1]
        task = asyncio.ensure_future(serve(s, sock, f"http://127.0.0.1:{port}/", log=logs.append))
        await asyncio.sleep(0.1)
        try:
            await scenario(port)
        finally:
            task.cancel()
            with pytest.raises(asyncio.CancelledError):
                await task
            s.close()

    asyncio.run(main())
    return logs


def test_a_foreign_host_gets_403_and_the_page_its_own_host_200(capfd: pytest.CaptureFixture[str]) -> None:
    answers: dict[str, bytes] = {}
    ports: list[int] = []

    async def scenario(port: int) -> None:
        ports.append(port)
        loop = asyncio.get_running_loop()
        for name, host in (("evil", f"evil.example:{port}"), ("none", None), ("own", f"127.0.0.1:{port}"),
                           ("localhost", f"localhost:{port}")):
            answers[name] = await loop.run_in_executor(None, _get, port, host)
        ws_request = (b"GET /ws HTTP/1.1\r\nHost: evil.example\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
                      b"Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n")
        answers["ws"] = await loop.run_in_executor(None, _raw, port, ws_request)
        answers["static"] = await loop.run_in_executor(None, _raw, port, b"GET /static/view.js HTTP/1.1\r\n"
                                                       b"Host: rebound.example\r\nConnection: close\r\n\r\n")

    logs = [line.replace(f"evil.example:{ports[0]}", "evil.example:PORT") for line in _serve(scenario)]
    assert answers["none"].startswith(b"HTTP/1.0 400 Bad Request")  # aiohttp's own rule for HTTP/1.1
    for name in ("evil", "ws", "static"):
        status, _, body = answers[name].partition(b"\r\n\r\n")
        assert status.startswith(b"HTTP/1.1 403 Forbidden"), answers[name][:200]
        assert body.decode().startswith(f"403 Forbidden: {REFUSED_HOST}; this request named ")
    assert answers["own"].startswith(b"HTTP/1.1 200 OK") and b"labsim view" in answers["own"]
    assert answers["localhost"].startswith(b"HTTP/1.1 200 OK")
    assert logs == ["labsim view: refused a request from 127.0.0.1 for host 'evil.example:PORT'",
                    "labsim view: refused a malformed request from 127.0.0.1: \"Missing 'Host' header in request.\"; "
                    "the connection is closed",
                    "labsim view: refused a request from 127.0.0.1 for host 'evil.example'",
                    "labsim view: refused a request from 127.0.0.1 for host 'rebound.example'"]
    assert "Traceback" not in capfd.readouterr().err


def test_a_200_kb_header_is_refused_in_one_line(capfd: pytest.CaptureFixture[str]) -> None:
    answer: list[bytes] = []

    async def scenario(port: int) -> None:
        loop = asyncio.get_running_loop()
        answer.append(await loop.run_in_executor(None, _get, port, "127.0.0.1", b"X-Big: " + b"a" * 200_000 + b"\r\n"))
        answer.append(await loop.run_in_executor(None, _get, port, "127.0.0.1"))  # and it goes on

    logs = _serve(scenario)
    assert answer[0].startswith(b"HTTP/1.0 400 Bad Request")
    assert answer[1].startswith(b"HTTP/1.1 200 OK")
    assert logs == ["labsim view: refused a request from 127.0.0.1: a header or request line longer than 8190 bytes "
                    "(the limit); the connection is closed"]
    assert "Traceback" not in capfd.readouterr().err


def test_a_5000_digit_integer_is_labsims_number_error(capfd: pytest.CaptureFixture[str]) -> None:
    async def scenario(port: int) -> None:
        async with aiohttp.ClientSession() as http:
            ws = await http.ws_connect(f"http://127.0.0.1:{port}/ws")
            await ws.send_str('{"type": "speed", "value": ' + "9" * 5000 + "}")
            await ws.send_str('{"type": "seek", "tick": ' + "9" * 400 + "}")
            await ws.send_str('{"type": "select", "robot": ' + "9" * 300 + "}")  # fits a float: a bad index
            await ws.send_str(json.dumps({"type": "step"}))
            for _ in range(100):
                msg = await ws.receive_json(timeout=10)
                if msg["type"] == "frame" and msg["ran"] == 1:
                    break
            assert msg["ran"] == 1  # the run went on
            await ws.close()

    logs = _serve(scenario)
    assert logs == [
        f"labsim view: ignored a message from 127.0.0.1 (1 so far): a number in it: {TOO_LARGE} (5000 characters)",
        f"labsim view: ignored a message from 127.0.0.1 (2 so far): a number in it: {TOO_LARGE}",
    ]
    assert "Traceback" not in capfd.readouterr().err


def test_300_connections_share_one_log_limit() -> None:
    async def scenario(port: int) -> None:
        async with aiohttp.ClientSession() as http:
            for _ in range(300):
                ws = await http.ws_connect(f"http://127.0.0.1:{port}/ws")
                await ws.send_str("{bad")
                await ws.send_str("[1, 2")
                await ws.close()
            # the server has read every message once a later page's step is answered
            ws = await http.ws_connect(f"http://127.0.0.1:{port}/ws")
            await ws.send_str(json.dumps({"type": "step"}))
            for _ in range(100):
                msg = await ws.receive_json(timeout=10)
                if msg["type"] == "frame" and msg["ran"] == 1:
                    break
            await ws.close()

    logs = _serve(scenario)
    assert len(logs) == LOG_LIMIT + 1  # 600 ignored: twenty lines, then the hundredth
    assert logs[-1].startswith("labsim view: ignored a message from 127.0.0.1 (100 so far): ")


# -- the command line -------------------------------------------------------------------------

@pytest.mark.slow
def test_listening_on_every_address_warns_once() -> None:
    p = subprocess.Popen([sys.executable, "-m", "labsim", "view", str(WALL), "--host", "0.0.0.0", "--port", "0",
                          "--no-browser"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT)
    assert p.stdout is not None
    started = p.stdout.readline()
    time.sleep(0.5)
    p.terminate()
    _, err = p.communicate(timeout=60)
    assert "labsim view: running" in started
    assert err.count("labsim view: warning: listening on every address of this machine, port ") == 1, err
    assert "Traceback" not in err


def test_a_trace_of_too_many_columns_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "wide.csv"
    extra = [f"c{k}" for k in range(MAX_COLUMNS)]
    w = TraceWriter(path, header(), COLUMNS + extra)
    try:
        w.write([0, 0.0, "pioneer", 0.0, 0.0, 0.0, 0, "go", "go:1", 1.0, 1.0, ""] + [0.0] * len(extra))
    finally:
        w.close()
    assert main(["view", str(path), "--no-browser", "--port", "0"]) == 2
    err = capsys.readouterr().err
    assert f"{path}: error: {len(COLUMNS) + MAX_COLUMNS:,} columns: labsim view replays a trace of at most " \
           f"{MAX_COLUMNS:,} (its page could not hold more); labsim plot and labsim.read_trace read it" in err
    assert "Traceback" not in err
