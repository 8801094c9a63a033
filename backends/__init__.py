"""Simulator backends behind one small protocol (``labsim.backends.protocol``).

Backends are registered as "module:Class" strings and imported only when chosen, so the
CoppeliaSim client is never imported by a run on the embedded backend.
"""
from __future__ import annotations

import importlib

from labsim.backends.protocol import Backend, BackendError

REGISTRY: dict[str, str] = {
    "pymunk": "labsim.backends.pymunk.backend:PymunkBackend",
}

DEFAULT = "pymunk"


def load_backend(name: str, **options: object) -> Backend:
    """Create the backend registered as ``name``; raises BackendError for an unknown name."""
    try:
        target = REGISTRY[name]
    except KeyError:
        known = ", ".join(sorted(REGISTRY))
        raise BackendError(f"unknown backend '{name}' (known: {known})") from None
    module_name, class_name = target.split(":")
    cls = getattr(importlib.import_module(module_name), class_name)
    return cls(**options)
