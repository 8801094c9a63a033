"""Simulator backends behind one small protocol (``labsim.backends.protocol``).

Backends are registered as "module:Class" strings and imported only when chosen, so the
CoppeliaSim client is never imported by a run on the embedded backend.
"""
from __future__ import annotations

import importlib
import inspect

from labsim.backends.protocol import Backend, BackendError

REGISTRY: dict[str, str] = {
    "pymunk": "labsim.backends.pymunk.backend:PymunkBackend",
    "coppeliasim": "labsim.backends.coppeliasim.backend:CoppeliaSimBackend",
}

DEFAULT = "pymunk"


def load_backend(name: str, **options: object) -> Backend:
    """Create the backend registered as ``name`` with its options (``host``, ``port``,
    ``timeout_s`` for coppeliasim); raises BackendError for an unknown name or option."""
    try:
        target = REGISTRY[name]
    except KeyError:
        known = ", ".join(sorted(REGISTRY))
        raise BackendError(f"unknown backend '{name}' (known: {known})") from None
    module_name, class_name = target.split(":")
    cls = getattr(importlib.import_module(module_name), class_name)
    accepted = inspect.signature(cls).parameters
    for option in options:
        if option not in accepted:
            raise BackendError(f"backend '{name}' has no option '{option}'"
                               f" (it takes: {', '.join(accepted) or 'none'})")
    return cls(**options)
