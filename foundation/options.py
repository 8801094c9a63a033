"""Argument types for the command line: each option's range, checked by argparse itself.

A value out of range is argparse's own ``labsim: error: argument --timeout: ...`` with the
usage line and exit code 2, before anything runs; the library below never sees a timeout of
1e308 seconds (which overflowed ZMQ's milliseconds) or a host that is no host.
"""
from __future__ import annotations

import argparse
import ipaddress
import math
import re

from labsim.foundation.limits import MAX_DT_S, MIN_DT_S

MAX_TIMEOUT_S = 3600.0  # a simulator that answers nothing for an hour is not coming back
MIN_TIMEOUT_S = 0.01
MAX_SERVE_ROBOTS = 1000  # as Budgets.robots: what one simulated scene holds

# A host name as DNS writes it (RFC 1123 labels, at most 253 characters in all).
_LABEL = re.compile(r"(?!-)[A-Za-z0-9-]{1,63}(?<!-)")


def _number(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a number") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"'{text}' is not a finite number")
    return value


def timeout_s(text: str) -> float:
    """Seconds to wait for a simulator: from MIN_TIMEOUT_S to MAX_TIMEOUT_S."""
    value = _number(text)
    if not MIN_TIMEOUT_S <= value <= MAX_TIMEOUT_S:
        raise argparse.ArgumentTypeError(f"give from {MIN_TIMEOUT_S:g} to {MAX_TIMEOUT_S:g} seconds, not {text}")
    return value


def run_timeout_s(text: str) -> float:
    """A sweep's real-time limit on one run: from MIN_TIMEOUT_S to a day."""
    value = _number(text)
    if not MIN_TIMEOUT_S <= value <= 86_400:
        raise argparse.ArgumentTypeError(f"give from {MIN_TIMEOUT_S:g} to 86400 seconds (a day), not {text}")
    return value


def port(text: str) -> int:
    """A TCP port, 0 to 65535 (0: a free one, where the command says so)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a port number") from None
    if not 0 <= value <= 65535:
        raise argparse.ArgumentTypeError(f"a port is from 0 to 65535, not {text}")
    return value


def host(text: str) -> str:
    """A host name (letters, digits, '-' and '.') or an IPv4 or IPv6 address; '*' for every
    interface, as ZMQ binds."""
    if text == "*":
        return text
    try:
        ipaddress.ip_address(text.strip("[]"))
        return text
    except ValueError:
        pass
    name = text[:-1] if text.endswith(".") else text
    if 0 < len(name) <= 253 and all(_LABEL.fullmatch(label) for label in name.split(".")):
        return text
    shown = text if len(text) <= 60 else text[:60] + "..."
    raise argparse.ArgumentTypeError(f"'{shown}' is not a host name or an IP address")


def time_step_s(text: str) -> float:
    """A simulation time step, in the range a behaviour's ``dt`` has."""
    value = _number(text)
    if not MIN_DT_S <= value <= MAX_DT_S:
        raise argparse.ArgumentTypeError(f"give from {MIN_DT_S:g} to {MAX_DT_S:g} seconds, not {text}")
    return value


def robots(text: str) -> int:
    """A number of robots for ``labsim serve``: 0 to MAX_SERVE_ROBOTS."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a whole number") from None
    if not 0 <= value <= MAX_SERVE_ROBOTS:
        raise argparse.ArgumentTypeError(f"give 0 to {MAX_SERVE_ROBOTS} robots, not {text}")
    return value
