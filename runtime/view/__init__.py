"""``labsim view``: watch and steer a run, or replay a trace, in the browser.

The command line (``labsim.runtime.cli.commands.cmd_view``) calls ``view``. It builds a session, a
live run (``live``) of a behaviour file or a replay (``replay``) of a trace, binds the web
server's socket (``server``) on loopback unless told otherwise, prints the URL, opens it
unless asked not to, and serves the page (``static/``) until Ctrl-C. Frames and messages are
described in docs/view.md.
"""
from __future__ import annotations

import asyncio
import os
import secrets
import signal
import socket
import sys
from collections.abc import Callable

from labsim.foundation.diagnostics import Diagnostic, LabsimError
from labsim.foundation.exits import EXIT_HANGUP, EXIT_INTERRUPTED, EXIT_OK, EXIT_TERMINATED, EXIT_USAGE
from labsim.foundation.kinds import file_kind
from labsim.foundation.limits import DEFAULT_BUDGETS, Budgets
from labsim.runtime.trace import TraceFormatError
from labsim.runtime.view.session import Session

DEFAULT_PORT = 8765


def view(path: str, *, overrides: dict[str, str], seed: int | None = None, backend: str = "pymunk",
         backend_options: dict[str, object] | None = None, host: str = "127.0.0.1",
         port: int = DEFAULT_PORT, trace: str | None = None, open_browser: bool = True,
         warn: Callable[[str], None], report: Callable[[list[Diagnostic]], None],
         budgets: Budgets = DEFAULT_BUDGETS, breaks: list[str] | None = None, read_only: bool = False,
         token: bool = True) -> int:
    """Serve the page for a behaviour file or a trace until Ctrl-C; the exit code.

    A behaviour that does not compile is reported (``report``) and the page shows the same
    diagnostics until it is fixed (the page's Check again) or the server is stopped; the exit
    code is then 2. Ctrl-C gives 130 (SIGTERM 143, SIGHUP 129), the trace so far kept and
    closed with its footer. ``token`` False (``--no-token``) serves without a session token,
    with a warning, and the page cannot save the file.
    """
    from labsim.runtime.interrupts import StopSignals
    from labsim.runtime.view.live import LiveSession
    from labsim.runtime.view.server import serve

    if not 0 <= port < 65536:
        raise LabsimError([Diagnostic(f"--port {port}", "give a port from 1 to 65535, or 0 for a free one")])
    session = _session(path, overrides, seed, backend, backend_options, trace, warn, breaks or [], read_only, budgets)
    broken = False
    if isinstance(session, LiveSession) and not session.load():
        refused = [d for d in session.problems if d.path.startswith(("--trace ", "--break", "--set ", "--seed"))]
        if refused:  # an output over an input, a bad breakpoint or --set: the command line's mistake, no page, exit 2
            session.close()
            raise LabsimError(refused)
        report(session.problems)
        broken = True
    sock, url, key = _listen(session, host, port, token, warn)
    if isinstance(session, LiveSession):
        session.can_save = key is not None

    def ready(_server: object) -> None:
        what = "replaying" if not hasattr(session, "load") else "running"
        print(f"labsim view: {what} {path} at {url}  (Ctrl-C stops)", flush=True)

    interrupted = 0
    try:
        # Ctrl-C, SIGTERM and SIGHUP only set a flag the tick loop reads: raised inside one of
        # chipmunk's callbacks, an exception would be lost and the view run on without end
        with StopSignals() as stop:
            asyncio.run(serve(session, sock, url, log=warn, open_browser=open_browser, ready=ready, host=host,
                              token=key, stop=stop))
        interrupted = stop.signum
    except KeyboardInterrupt:
        interrupted = signal.SIGINT
    finally:
        session.close()  # a --trace gets its footer
        sock.close()
    broken = broken and not getattr(session, "ever_ran", False)
    return EXIT_USAGE if broken else _stopped(interrupted) if interrupted else EXIT_OK


def _listen(session: Session, host: str, port: int, token: bool,
            warn: Callable[[str], None]) -> tuple[socket.socket, str, str | None]:
    """The page's socket, its URL (with the session token unless ``--no-token``) and the token;
    a port that cannot be used is the command line's mistake (the session closed)."""
    from labsim.runtime.view.guard import exposure_warning
    from labsim.runtime.view.server import bind_socket, url_of

    try:
        sock = bind_socket(host, port)
    except OSError as e:
        session.close()
        why = "is in use" if e.errno in (48, 98, 10048) else f"cannot be used: {e.strerror or e}"
        raise LabsimError([Diagnostic(f"--port {port}", f"port {port} on {host} {why}",
                                      notes=("pick another with --port, or --port 0 for a free one",))]) from None
    key = secrets.token_urlsafe(24) if token else None
    url = url_of(sock, host) + (f"?token={key}" if key else "")
    exposed = exposure_warning(host, sock.getsockname()[0], sock.getsockname()[1])
    if exposed:
        warn(exposed)
    if key is None:
        warn(f"labsim view: warning: --no-token: any program or person that can reach port {sock.getsockname()[1]} "
             "can watch and steer the run without the URL; the page cannot save the file")
    return sock, url, key


def _stopped(interrupted: int) -> int:
    """The exit code of a view a signal stopped (130 Ctrl-C, 143 SIGTERM, 129 SIGHUP), said on stderr."""
    code = {signal.SIGINT: EXIT_INTERRUPTED, signal.SIGTERM: EXIT_TERMINATED,
            getattr(signal, "SIGHUP", -1): EXIT_HANGUP}.get(interrupted, EXIT_INTERRUPTED)
    how = {EXIT_TERMINATED: " (SIGTERM)", EXIT_HANGUP: " (SIGHUP)"}.get(code, "")
    sys.stderr.write(f"labsim view: stopped{how}\n")
    return code


def _session(path: str, overrides: dict[str, str], seed: int | None, backend: str,
             backend_options: dict[str, object] | None, trace: str | None,
             warn: Callable[[str], None], breaks: list[str], read_only: bool = False,
             budgets: Budgets = DEFAULT_BUDGETS) -> Session:
    from labsim.runtime.view.live import LiveSession
    from labsim.runtime.view.replay import load_replay

    if not os.path.lexists(path):  # anything else there is for the one way in to judge
        raise LabsimError([Diagnostic(path, "no such file")])
    if file_kind(path) in ("trace", "golden"):  # else a behaviour: its loader says what is wrong
        for flag, given in (("--set", overrides), ("--seed", seed is not None), ("--trace", trace),
                            ("--break", breaks)):
            if given:
                raise LabsimError([Diagnostic(flag, f"a replayed trace takes no {flag}")])
        try:
            replay = load_replay(path)
        except TraceFormatError as e:
            raise LabsimError([e.diagnostic(path)]) from None
        if replay.trace.cut_short():
            warn(f"{path}: warning: {replay.trace.cut_short()}; replaying the ticks it has")
        return replay
    if seed is not None and seed < 0:
        raise LabsimError([Diagnostic("--seed", "the seed is 0 or a positive whole number")])
    return LiveSession(path, overrides, seed=seed, backend=backend, backend_options=backend_options,
                       trace=trace, warn=warn, breaks=breaks, read_only=read_only, budgets=budgets)
