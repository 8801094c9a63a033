"""labsim's version, as the installed distribution's metadata says it: pyproject.toml is its one source.

Read on first use and kept: ``importlib.metadata`` and the look-up cost about 25 ms, which a
``labsim check`` that prints no version should not pay. It lives in the foundation, not in the
package root, so that the modules that write it (the trace header, the summary JSON, a sweep's
and a grade's output, ``labsim --version``) do not import ``labsim`` itself, whose lazy API
imports them back (docs/decisions.md §31).
"""
from __future__ import annotations

from functools import cache


@cache
def version() -> str:
    """The installed labsim's version (``0+unknown`` for a copy of the source that pip never installed)."""
    from importlib.metadata import PackageNotFoundError
    from importlib.metadata import version as distribution_version

    try:
        return distribution_version("labsim")
    except PackageNotFoundError:
        return "0+unknown"
