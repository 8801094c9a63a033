"""World names: what a world's name or path means, by one rule for every reader.

A behaviour's ``world:``, ``labsim serve WORLD`` and a trace's header name a world the same
way: a built-in world's name (``walls_lab4``; ``builtin_worlds`` lists them), or a world file's
path (a name that ends in ``.yaml`` or ``.yml``, has a folder in it, or is a file that is
there). ``find_world`` turns such a name into the file to read, which
``labsim.backends.scene.world_file.load_world`` then reads, or into the problem, worded once
for all of them. Where the name comes from decides where a relative path starts and what may
be read: a name the person running labsim typed is theirs, any file; a name from a file (a
behaviour, a trace) must keep to the access policy (``labsim.foundation.files``), which the
built-in worlds' own files always pass. ``builtin_name`` says whether a file is a built-in
world (a trace records no path for one). This module sits in the scene and imports only the
foundation.
"""
from __future__ import annotations

import functools
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from labsim.foundation.diagnostics import LabsimError, did_you_mean
from labsim.foundation.files import os_words, policy_notes, policy_problem, read_text
from labsim.foundation.kinds import YAML_SUFFIXES

BUILTIN_DIR = Path(__file__).parent / "worlds"


def builtin_worlds() -> dict[str, Path]:
    """Names of the worlds shipped with labsim, and their files."""
    return {p.stem: p for p in sorted(BUILTIN_DIR.glob("*.yaml"))}


@functools.cache
def _builtin_files() -> dict[Path, str]:
    """The built-in worlds' files, links followed (an editable install links each file), by name."""
    return {p.resolve(): name for name, p in builtin_worlds().items()}


def builtin_name(path: str | Path) -> str:
    """The built-in world's name when path is one of labsim's own world files, else ''."""
    p = Path(path)
    if p.parent == BUILTIN_DIR and p.suffix == ".yaml":
        return p.stem
    try:
        return _builtin_files().get(p.resolve(), "")
    except (OSError, RuntimeError):  # a loop of links is no built-in world
        return ""


def builtin_copy(path: str | Path, text: str) -> str:
    """The built-in world a file is a copy of (the same file name, the same text), else ''."""
    builtin = BUILTIN_DIR / Path(path).name
    if not os.path.isfile(builtin):
        return ""
    try:
        return builtin.stem if read_text(builtin, "world") == text else ""
    except LabsimError:
        return ""


@dataclass(frozen=True)
class WorldRef:
    """Where a world's name leads: the file to read, or why there is none (``problem``, with
    ``notes``); ``refused`` when the access policy refused it (``--allow-path`` would open it)."""

    path: Path | None
    problem: str = ""
    notes: tuple[str, ...] = ()
    refused: bool = False


def find_world(name: str, base: Path | None = None, *, look_in: Sequence[Path] = (),
               allowed: Sequence[Path] | None = None) -> WorldRef:
    """The world file ``name`` means: a built-in world's, or a path's.

    ``base`` None: the person running labsim typed it; a path is relative to the current folder
    and may be any file. ``base`` a folder: a file named it (a behaviour: its own folder); a
    path is relative to ``base``, then to each of ``look_in``, and must keep to the access
    policy: inside that folder, one of ``allowed`` (default: the ``--allow-path`` folders), or a
    built-in world's file."""
    known = builtin_worlds()
    if not name.strip():
        return WorldRef(None, "'world' needs a built-in world's name or a path to a world file",
                        (f"built-in worlds: {', '.join(known)}",))
    if name in known:
        return WorldRef(known[name])
    folders = [base if base is not None else Path("."), *look_in]
    if not (name.endswith(YAML_SUFFIXES) or "/" in name or os.sep in name
            or any(os.path.isfile(f / name) for f in folders)):
        return WorldRef(None, f"unknown world '{name}'{did_you_mean(name, known)}",
                        ("built-in worlds: " + ", ".join(known) + "; or give a path to a world file",))
    refusal = ""
    for folder in folders:
        path = folder / name
        refused = base is not None and not builtin_name(path) and policy_problem(name, folder, allowed)
        if refused:  # docs/security.md: a file reads its own folder only
            refusal = refusal or refused
            continue
        missing = _missing(path)
        if missing is None:
            return WorldRef(path)
        if missing:
            return WorldRef(None, missing)
    if refusal:
        return WorldRef(None, f"world file '{name}' {refusal}", policy_notes(), refused=True)
    meant = _builtin_meant(name, known)
    if meant:
        where, write = ("beside this behaviour", f"world: {meant}") if base is not None else ("here", meant)
        return WorldRef(None, f"no file '{name}' {where}; the built-in world is named '{meant}' (write {write})")
    return WorldRef(None, f"world file '{name}' not found (looked for {folders[0] / name})")


def _builtin_meant(name: str, known: dict[str, Path]) -> str:
    """The built-in world a missing file's name means (``walls_lab4.yaml``,
    ``worlds/walls_lab4.yaml``: a built-in world's name, written as its file), else ''."""
    stem = Path(name).name
    for suffix in YAML_SUFFIXES:
        stem = stem.removesuffix(suffix)
    return stem if stem in known and stem != name else ""


def _missing(path: Path) -> str | None:
    """None when the world file is there to read; '' when it does not exist; else why the
    system refuses it (a name too long, a folder the user may not enter), in its words."""
    try:
        os.stat(path)
    except (FileNotFoundError, NotADirectoryError):
        return ""
    except OSError as e:
        name = str(path.name)
        shown = name if len(name) <= 80 else f"{name[:60]}... ({len(name)} characters)"
        return f"world file '{shown}' cannot be opened: {os_words(e)}"
    return None
