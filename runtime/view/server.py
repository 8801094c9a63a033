"""The web server of ``labsim view``: one page, its static files, and a WebSocket of frames.

aiohttp serves HTTP and WebSockets from one event loop (docs/decisions.md says why). The
session (a live run or a replayed trace) lives in this process; a pacing task calls
``Session.catch_up`` and sends every open page one frame, at most 30 times a second. A page
that acknowledges frames (``{"type": "ack"}``, sent once it has drawn one) gets the next only
after it did, and a frame nobody is ready for is not built: the tick loop never waits for a
browser, and a slow page gets fewer frames rather than a queue of them. Pages
send small JSON messages (docs/view.md); one that is malformed, unknown or hostile is logged
and ignored, and never reaches the run. Every page sees the same run; each page picks which
robot's camera it receives. A WebSocket must come from the page's own origin (or from a
client that sends no Origin), so another web site open in the browser cannot steer the run,
and every request must name this server as its ``Host`` (``labsim.runtime.view.guard``), so
that a site cannot reach it under a name of its own either (DNS rebinding). Every request
must also carry the session token (``?token=`` in the URL ``labsim view`` prints, then a
cookie the first answer sets, as Jupyter does): another user of the machine, or of the network
with ``--host 0.0.0.0``, who can reach the port but never saw the URL gets ``403`` for the
page, its files and its WebSocket alike. Numbers in a
message follow labsim's rule for numbers (an integer too large for a float is refused while
the message is read), and everything the server logs, across all connections, shares one
limit.
"""
from __future__ import annotations

import asyncio
import hmac
import json
import socket
import webbrowser
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from aiohttp import WSMsgType, web

from labsim.foundation.numbers import NumberError, to_float
from labsim.runtime.interrupts import StopSignals
from labsim.runtime.view.frames import FLAT_OUT_INTERVAL_S, FRAME_INTERVAL_S, Json, message, number
from labsim.runtime.view.guard import REFUSED_HOST, LogBudget, host_allowed, http_logger
from labsim.runtime.view.session import BadMessage, ChangeRefused, Session

# resolved: an install may reach this module through links, and the static route serves only
# files that really lie inside the folder it is given
STATIC = Path(__file__).resolve().parent / "static"
MAX_MESSAGE_BYTES = 64 * 1024
ACK_WAIT_S = 0.004  # at a set speed, how long the loop sleeps before looking again for a page ready for a frame
REFUSED_TOKEN = ("403 Forbidden: this page needs its session token. Open the address labsim view printed "
                 "(it ends in ?token=...); the token is new each time labsim view starts.\n")
GOODBYE = 4000  # the WebSocket close code of a server that ends on purpose: the page does not reconnect


@dataclass(eq=False)
class Page:
    """One open page: its socket, the robot whose camera it shows, whether a send is under way,
    and, for a page that acknowledges frames (``acks``), whether the last one is not yet
    acknowledged (``waiting``). A client that never acknowledges gets every frame it can take."""

    ws: web.WebSocketResponse
    peer: str
    robot: int = 0
    busy: bool = False
    acks: bool = False
    waiting: bool = False

    @property
    def ready(self) -> bool:
        return not self.busy and not (self.acks and self.waiting)


class ViewServer:
    """See the module docstring. ``log`` takes one line per notable event, within one budget;
    ``host`` is the ``--host`` the server listens on (the names it answers to)."""

    def __init__(self, session: Session, log: Callable[[str], None], host: str = "127.0.0.1",
                 token: str | None = None, port: int = 0):
        self.session = session
        self.log = LogBudget(log)
        self.host = host
        self.token = token  # None: --no-token, every request is served
        # a cookie is the host's, whatever its port: two views on one machine keep theirs apart
        self.cookie = f"labsim_view_token_{port}"
        self.ignored = 0  # messages ignored, from every page
        self.pages: list[Page] = []
        self.dirty = True  # something changed since the last frame
        self._tasks: set[asyncio.Task[None]] = set()
        self.app = web.Application(client_max_size=MAX_MESSAGE_BYTES, middlewares=[self._check_host, self._check_token])
        self.app.router.add_get("/", self._index)
        self.app.router.add_get("/ws", self._socket)
        self.app.router.add_get("/favicon.ico", self._no_icon)
        self.app.router.add_static("/static/", STATIC)

    # -- HTTP -------------------------------------------------------------------------------
    @web.middleware
    async def _check_host(self, request: web.Request, handler: Any) -> web.StreamResponse:
        """Every request, the page's, its files' and the WebSocket's, must name this server."""
        host = request.headers.get("Host")
        if not host_allowed(host, self.host):
            self.log(f"labsim view: refused a request from {request.remote or '?'} for host {(host or '')[:80]!r}")
            return web.Response(status=403, text=f"403 Forbidden: {REFUSED_HOST}; this request named "
                                                 f"{(host or 'no host')[:80]!r}.\n")
        response: web.StreamResponse = await handler(request)
        return response

    @web.middleware
    async def _check_token(self, request: web.Request, handler: Any) -> web.StreamResponse:
        """Every request carries the session token: in the query (the printed URL; the page's
        address then drops it, and a cookie carries it from there on) or in the cookie."""
        if self.token is None:
            response: web.StreamResponse = await handler(request)
            return response
        given = request.query.get("token")
        if given is not None and _same(given, self.token):
            if request.path == "/" and request.method in ("GET", "HEAD"):
                # the token into a cookie, and out of the address bar (and the browser's history)
                rest = [(k, v) for k, v in request.query.items() if k != "token"]
                found = web.HTTPFound(str(request.rel_url.with_query(rest)))
                found.set_cookie(self.cookie, self.token, httponly=True, samesite="Strict", path="/")
                raise found
            response = await handler(request)
            return response
        if _same(request.cookies.get(self.cookie, ""), self.token):
            response = await handler(request)
            return response
        why = "a wrong token" if given is not None else "no session token"
        self.log(f"labsim view: refused a request from {request.remote or '?'} for {request.path[:80]!r}: {why}")
        return web.Response(status=403, text=REFUSED_TOKEN)

    async def _index(self, request: web.Request) -> web.StreamResponse:
        return web.FileResponse(STATIC / "index.html", headers={
            "Cache-Control": "no-store",
            "Content-Security-Policy": "default-src 'self'; img-src 'self' data:; style-src 'self' 'unsafe-inline'; "
                                       "connect-src 'self' ws: wss:"})

    async def _no_icon(self, request: web.Request) -> web.StreamResponse:
        return web.Response(status=204)

    async def _socket(self, request: web.Request) -> web.StreamResponse:
        origin = request.headers.get("Origin")
        if origin is not None and origin.split("://", 1)[-1] != request.host:
            self.log(f"labsim view: refused a WebSocket from origin {origin[:80]}")
            raise web.HTTPForbidden(text="this run only answers its own page")
        # no permessage-deflate: a frame is under 4 KB and the page usually on this machine, where
        # deflating it here and inflating it in the browser is CPU both sides spend for nothing
        ws = web.WebSocketResponse(max_msg_size=MAX_MESSAGE_BYTES, heartbeat=20, compress=False)
        await ws.prepare(request)
        page = Page(ws, request.remote or "?")
        self.pages.append(page)
        try:
            # the run so far before the first frame (a new tab, a reload, a reconnect); the path
            # points and samples since the last frame stay for the pages already open, if any
            await ws.send_str(_dumps(self.session.scene()))
            await ws.send_str(_dumps(self.session.history()))
            alone = all(p is page for p in self.pages)
            await ws.send_str(self._frame_text(page, _dumps(self.session.frame(take=alone))))
            async for msg in ws:
                if msg.type == WSMsgType.TEXT:
                    await self._message(page, msg.data)
                elif msg.type == WSMsgType.BINARY:
                    self._ignore(page, "binary messages are not understood")
                elif msg.type == WSMsgType.ERROR:
                    self._ignore(page, f"the connection failed: {ws.exception()}")
        finally:
            if page in self.pages:
                self.pages.remove(page)
        return ws

    async def _message(self, page: Page, text: str) -> None:
        try:
            msg = json.loads(text, parse_int=_whole)
        except NumberError as e:
            self._ignore(page, f"a number in it: {e}")
            return
        except (ValueError, RecursionError):  # JSONDecodeError is a ValueError
            self._ignore(page, f"not JSON: {text[:60]!r}")
            return
        if isinstance(msg, dict) and msg.get("type") == "ack":
            # the page drew the last frame: it may have the next (nothing changed: not dirty)
            page.acks, page.waiting = True, False
            return
        try:
            if isinstance(msg, dict) and msg.get("type") == "select":
                robot = msg.get("robot")
                if isinstance(robot, bool) or not isinstance(robot, int) or robot < 0:
                    raise BadMessage("'robot' must be a robot's index")
                page.robot = robot
            else:
                if self.session.handle(msg):
                    await self.broadcast(_dumps(self.session.scene()))
                # a replay's seek: the rows up to there, as played, sent by the pacing loop before
                # the next frame (a scrubber dragged sends dozens of seeks: one history for them all)
        except BadMessage as e:
            self._ignore(page, str(e))
            return
        except ChangeRefused as e:  # the page that asked is told why; the run goes on
            await self._send(page, _dumps(message("error", diagnostics=e.diagnostics, places=e.places)))
        except Exception as e:  # a page must not be able to stop the run: say what failed, go on
            self._ignore(page, f"it failed: {type(e).__name__}: {e}")
        self.dirty = True

    def _ignore(self, page: Page, why: str) -> None:
        self.ignored += 1
        self.log(f"labsim view: ignored a message from {page.peer} ({self.ignored} so far): {why}")

    # -- frames -----------------------------------------------------------------------------
    def _frame_json(self) -> str:
        return _dumps(self.session.frame())

    def _frame_text(self, page: Page, frame: str, cache: dict[int, str] | None = None) -> str:
        """The frame for one page: the common part with that page's robot's images spliced in."""
        if cache is not None and page.robot in cache:
            images = cache[page.robot]
        else:
            images = _dumps(self.session.images(page.robot))
            if cache is not None:
                cache[page.robot] = images
        return frame[:-1] + ',"images":' + images + "}"

    async def send_frame(self) -> bool:
        """A frame to every page ready for one (False, and no frame built, when none is: its
        path points and chart samples then wait in the recorder for the next)."""
        ready = [page for page in self.pages if page.ready]
        if not ready:
            return False
        frame = self._frame_json()
        cache: dict[int, str] = {}
        for page in ready:  # a page still receiving or drawing the last frame skips this one
            page.waiting = True
            self._spawn(self._send(page, self._frame_text(page, frame, cache)))
        self.dirty = False
        return True

    async def broadcast(self, text: str) -> None:
        for page in list(self.pages):
            await self._send(page, text)

    async def _send(self, page: Page, text: str) -> None:
        page.busy = True
        try:
            await page.ws.send_str(text)
        except (ConnectionError, RuntimeError):
            if page in self.pages:
                self.pages.remove(page)
        finally:
            page.busy = False

    def _spawn(self, coro: Any) -> None:
        task = asyncio.ensure_future(coro)
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)

    async def pace(self, stop: StopSignals | None = None) -> None:
        """Tick and send frames until cancelled: at most one frame per 1/30 s (1/20 s at "as
        fast as it goes", see ``FLAT_OUT_INTERVAL_S``).

        At a set speed the loop sleeps between frames; at "as fast as it goes" it ticks until
        the next frame is due and only yields to the event loop in between, so the pages'
        messages are still read. A frame that is due while no page is ready for it (each is
        drawing the last) waits: the run ticks on in short stretches (or, at a set speed, the
        loop sleeps a few milliseconds) until a page acknowledges.
        """
        loop = asyncio.get_running_loop()
        session = self.session
        last_frame = -FRAME_INTERVAL_S
        ran = 0
        while stop is None or not stop.signum:
            now = loop.time()
            flat_out = session.playing and session.pacer.speed is None
            interval = FLAT_OUT_INTERVAL_S if flat_out else FRAME_INTERVAL_S
            budget = max(0.004, last_frame + interval - now) if flat_out else FRAME_INTERVAL_S * 0.8
            before = (session.playing, session.finished)
            ran += session.catch_up(budget)
            if (session.playing, session.finished) != before:
                # the stop seen on a tick that ran nothing (the frame before went out with the
                # last tick): the pages must still hear that the run ended
                self.dirty = True
            now = loop.time()
            waiting = False
            if getattr(session, "jumped", False) and self.pages:
                await self.broadcast(_dumps(session.history()))
                self.dirty = True
            if now - last_frame >= interval:
                if (ran or self.dirty or session.playing) and self.pages and not await self.send_frame():
                    waiting = True  # due, but every page is busy with the last one: again soon
                else:
                    last_frame, ran = now, 0
            if flat_out and session.playing:
                await asyncio.sleep(0)
            elif waiting:
                await asyncio.sleep(ACK_WAIT_S)
            else:
                await asyncio.sleep(max(0.0, last_frame + interval - loop.time()))


def bind_socket(host: str, port: int) -> socket.socket:
    """A listening socket on host:port (0: a free port); OSError when that cannot be."""
    family, kind, proto, _, address = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)[0]
    sock = socket.socket(family, kind, proto)
    try:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.bind(address)
        sock.listen(16)
    except OSError:
        sock.close()
        raise
    sock.setblocking(False)
    return sock


def url_of(sock: socket.socket, host: str) -> str:
    port = sock.getsockname()[1]
    shown = f"[{host}]" if ":" in host else host
    return f"http://{shown}:{port}/"


async def serve(session: Session, sock: socket.socket, url: str, *, log: Callable[[str], None],
                open_browser: bool = False, ready: Callable[[ViewServer], None] | None = None,
                host: str = "127.0.0.1", token: str | None = None, stop: StopSignals | None = None) -> None:
    """Serve until cancelled, or until ``stop`` has caught a signal; the caller closes the
    session. ``host`` is ``--host``; ``token`` the session token every request must carry
    (None: none, ``--no-token``); ``url`` the address to open, the token in it."""
    server = ViewServer(session, log, host, token=token, port=sock.getsockname()[1])
    session.stop = stop
    runner = web.AppRunner(server.app, access_log=None, handle_signals=False, shutdown_timeout=0.5,
                           logger=http_logger(server.log))
    await runner.setup()
    try:
        await web.SockSite(runner, sock).start()
        if ready is not None:
            ready(server)
        if open_browser:
            asyncio.get_running_loop().run_in_executor(None, webbrowser.open, url)
        await server.pace(stop)
    finally:
        for page in list(server.pages):
            # said plainly: the page shows that the server stopped and does not knock again
            await page.ws.close(code=GOODBYE, message=b"labsim view stopped")
        await runner.cleanup()


def _same(given: str, token: str) -> bool:
    """The token compared in constant time (a wrong guess says nothing of how close it came)."""
    return hmac.compare_digest(given.encode("utf-8", "replace"), token.encode("utf-8"))


def _whole(text: str) -> int:
    """An integer of a message, under labsim's number rule: one no float can hold is refused
    before Python reads it (a 5,000-digit integer would raise from deep in the decoder)."""
    to_float(text)
    return int(text)


def _dumps(doc: Json | None) -> str:
    try:
        return json.dumps(doc, separators=(",", ":"), allow_nan=False, default=str)
    except ValueError:  # a nan or inf in a field that was not cleaned: clean them all
        return json.dumps(_clean(doc), separators=(",", ":"), allow_nan=False, default=str)


def _clean(value: object) -> object:
    if isinstance(value, float):
        return number(value)
    if isinstance(value, dict):
        return {k: _clean(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_clean(v) for v in value]
    return value
