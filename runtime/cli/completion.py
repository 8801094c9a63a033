"""Shell completion for the ``labsim`` command line, through argcomplete.

``labsim`` completes its commands and options (argparse knows them), and three things only
labsim knows: where a behaviour file goes, the labs' names (``labsim run wa<Tab>`` gives
``wall_follow``) beside the YAML files; after ``--set``, the parameter names of the file already
on the line (``front=``, ``side=``); for ``labsim serve``, the built-in worlds. Completion runs
only when the shell asks (argcomplete's ``_ARGCOMPLETE`` variable), so an ordinary command pays
nothing for it. Enable it once in bash or zsh::

    eval "$(register-python-argcomplete labsim)"
"""
from __future__ import annotations

import argparse
import os
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from labsim.backends.scene.world_names import builtin_worlds
from labsim.foundation.diagnostics import LabsimError
from labsim.foundation.kinds import TRACE_SUFFIX, YAML_SUFFIXES
from labsim.foundation.yaml_data import load_data
from labsim.runtime.labs import labs

# the arguments that take a behaviour file or a lab's name, by their dest
BEHAVIOUR_DESTS = ("file", "files", "paths", "lab", "behaviour")


def autocomplete(parser: argparse.ArgumentParser) -> None:
    """Answer the shell's completion request, if this process is one, and exit; else nothing."""
    if "_ARGCOMPLETE" not in os.environ:
        return
    import argcomplete

    _attach(parser)
    argcomplete.autocomplete(parser)


def _attach(parser: argparse.ArgumentParser) -> None:
    """Set labsim's completers on the parser and every sub-parser."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub in action.choices.values():
                _attach(sub)
        elif action.dest in BEHAVIOUR_DESTS:  # argcomplete reads an action's `completer`
            setattr(action, "completer", behaviours)  # noqa: B010
        elif action.dest == "set":
            setattr(action, "completer", parameters)  # noqa: B010
        elif action.dest == "world":
            setattr(action, "completer", worlds)  # noqa: B010


def behaviours(prefix: str, **_: Any) -> list[str]:
    """The labs' names and the YAML files and folders that start with prefix."""
    out = [name for name in labs() if name.startswith(prefix)]
    folder, _sep, start = prefix.rpartition("/")
    base = Path(folder or ".")
    try:
        entries = sorted(base.iterdir())
    except OSError:
        return out
    for entry in entries:
        if not entry.name.startswith(start) or entry.name.startswith("."):
            continue
        text = f"{folder}/{entry.name}" if folder else entry.name
        if entry.is_dir():
            out.append(text + "/")
        elif entry.suffix in (*YAML_SUFFIXES, TRACE_SUFFIX):  # by name: the shell's Tab reads no file
            out.append(text)
    return out


def parameters(prefix: str, parsed_args: argparse.Namespace, **_: Any) -> list[str]:
    """NAME= for each parameter of the behaviour file already on the command line."""
    given = getattr(parsed_args, "file", None) or (getattr(parsed_args, "files", None) or [None])[0]
    if not given:
        return []
    path = Path(given) if os.path.exists(given) else labs()[given].path if given in labs() else None
    return [f"{name}=" for name in _parameter_names(path) if f"{name}=".startswith(prefix)] if path else []


def _parameter_names(path: Path) -> Iterable[str]:
    try:
        _, data = load_data(path, "behaviour")  # labsim's one reader; a FIFO must not hang the shell's Tab
    except LabsimError:
        return []
    params = data.get("params") if isinstance(data, dict) else None
    return [str(k) for k in params] if isinstance(params, dict) else []


def worlds(prefix: str, **_: Any) -> list[str]:
    return [name for name in builtin_worlds() if name.startswith(prefix)]
