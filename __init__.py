"""labsim: robotics labs as behaviour files.

The pipeline: ``labsim.dsl`` loads a behaviour file (YAML with source positions), parses its
rule strings, checks them and compiles them to plain Python callables; ``labsim.runtime`` runs
the compiled behaviour tick by tick on a backend from ``labsim.backends`` and writes traces,
summaries and plots.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Any

# The Python API (docs/api.md), imported on first use: `import labsim` stays cheap
__all__ = ["Behaviour", "LabsimError", "OverBudget", "RunStopped", "RunTimeout", "compile_behaviour", "load_backend",
           "read_trace", "run"]

if TYPE_CHECKING:
    from labsim.runtime.api import (
        Behaviour,
        LabsimError,
        OverBudget,
        RunStopped,
        RunTimeout,
        compile_behaviour,
        load_backend,
        read_trace,
        run,
    )


def __getattr__(name: str) -> Any:
    # the version as pip installed it (pyproject.toml); no module of labsim's reads it here
    if name == "__version__":
        from labsim.foundation.version import version

        return version()
    if name in __all__:
        from labsim.runtime import api

        return getattr(api, name)
    raise AttributeError(f"module 'labsim' has no attribute {name!r}")
