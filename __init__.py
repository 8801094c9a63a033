"""labsim: robotics labs as behaviour files.

The pipeline: ``labsim.dsl`` loads a behaviour file (YAML with source positions), parses its
rule strings, checks them and compiles them to plain Python callables; ``labsim.runtime`` runs
the compiled behaviour tick by tick on a backend from ``labsim.backends`` and writes traces,
summaries and plots.
"""
from __future__ import annotations

__version__ = "0.1.0"
