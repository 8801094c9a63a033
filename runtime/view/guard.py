"""The view server's defences: which Host it answers, what it logs, and how much.

``labsim.runtime.view.server`` asks ``host_allowed`` before it answers any request: a web page
from another site can point a name of its own at 127.0.0.1 (DNS rebinding) and then read the
page and steer the run as if it were the page's own origin, but the browser still sends that
name as ``Host``. So the server answers only loopback names and addresses and the ``--host``
it was started with; when that is every address (``0.0.0.0``, ``::``), it also answers any
address written as digits, which no DNS answer can change. ``LogBudget`` is the one limit
on what the server writes to stderr, across every connection; ``http_logger`` routes aiohttp's
own complaints (a malformed request, a 200 KB header) through it as one line, never a
traceback. ``exposure_warning`` is the line ``labsim view`` prints when it listens beyond
loopback. None of this reads the session.
"""
from __future__ import annotations

import ipaddress
import logging
from collections.abc import Callable

from aiohttp.http_exceptions import HttpProcessingError, LineTooLong

LOG_LIMIT = 20  # lines the server logs in full; after that, one at each power of ten
WILDCARDS = ("", "0.0.0.0", "::")  # --host values that listen on every address
REFUSED_HOST = ("labsim view answers only at its own address (localhost, 127.0.0.1, [::1], or the --host "
                "it was started with), so that a page from another site cannot reach the run; to open it "
                "under another name, start labsim view with --host THAT-NAME")


def _name(host: str) -> str:
    """A Host header or --host value without its port, brackets and letter case."""
    host = host.strip().lower()
    if host.startswith("["):  # [::1]:8765
        return host[1:].partition("]")[0]
    if host.count(":") == 1:  # 127.0.0.1:8765, localhost:8765; more colons: a bare IPv6 address
        host = host.partition(":")[0]
    return host.rstrip(".")


def _address(name: str) -> ipaddress.IPv4Address | ipaddress.IPv6Address | None:
    try:
        return ipaddress.ip_address(name)
    except ValueError:
        return None


def host_allowed(header: str | None, listen: str) -> bool:
    """Whether a request's ``Host`` header names this server as ``--host listen`` serves it."""
    if not header:
        return False  # every browser sends one; a request without it is no page of ours
    name, own = _name(header), _name(listen)
    if name == "localhost" or (name == own and own not in WILDCARDS):
        return True
    address = _address(name)
    return address is not None and (address.is_loopback or own in WILDCARDS)


def exposure_warning(listen: str, address: str, port: int) -> str | None:
    """The warning for a server listening on ``address`` beyond loopback; None on loopback."""
    bound = _address(address.partition("%")[0])
    if bound is not None and bound.is_loopback:
        return None
    where = "every address of this machine" if _name(listen) in WILDCARDS else f"{listen} ({address})"
    return (f"labsim view: warning: listening on {where}, port {port}: anyone who can reach it can watch "
            "and steer the run; leave out --host to keep it on this machine")


class LogBudget:
    """One limit on the server's log lines across all connections: ``LOG_LIMIT`` lines in
    full, then one at each power of ten (the hundredth, the thousandth...), with the count."""

    def __init__(self, log: Callable[[str], None]):
        self.log = log
        self.count = 0

    def __call__(self, line: str) -> None:
        self.count += 1
        n = self.count
        if n <= LOG_LIMIT:
            self.log(line)
        elif n >= 100 and str(n).rstrip("0") == "1":
            self.log(f"{line} (the server's log line {n}: past {LOG_LIMIT}, only lines 100, 1000, ... are shown)")


class _OneLine(logging.Handler):
    """aiohttp's records as one line through the budget: what happened, never a traceback."""

    def __init__(self, note: Callable[[str], None]):
        super().__init__(logging.WARNING)
        self.note = note

    def emit(self, record: logging.LogRecord) -> None:
        exc = record.exc_info[1] if record.exc_info else None
        peer = str(record.args[0]) if isinstance(record.args, tuple) and record.args else "?"
        if isinstance(exc, LineTooLong):
            self.note(f"labsim view: refused a request from {peer}: a header or request line longer than "
                      "8190 bytes (the limit); the connection is closed")
        elif isinstance(exc, HttpProcessingError):
            self.note(f"labsim view: refused a malformed request from {peer}: {str(exc.message)[:120]!r}; "
                      "the connection is closed")
        elif exc is not None:
            self.note(f"labsim view: a request failed: {type(exc).__name__}: {str(exc)[:120]}")
        else:
            self.note(f"labsim view: {record.getMessage()[:200]}")


def http_logger(note: Callable[[str], None]) -> logging.Logger:
    """A logger of this server's own for aiohttp (not registered globally): warnings and errors
    as one budgeted line each, its debug chatter dropped."""
    logger = logging.Logger("labsim.view.http", logging.WARNING)
    logger.propagate = False
    logger.addHandler(_OneLine(note))
    return logger
