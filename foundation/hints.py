"""What to try when a file named on the command line is not there, or is a folder.

``labsim.foundation.files`` raises the error; the notes under it come from here: the file beside
it with a close name, a shipped lab of a close name (``labsim labs``), or the files of the kind
asked for in the folder given.
"""
from __future__ import annotations

import difflib
import os
from pathlib import Path

# The labs labsim ships (runtime/labs.py names them): a behaviour not found is often one of
# them given by a wrong name, and a lab's name works wherever a behaviour file does.
SHIPPED_LABS = Path(__file__).resolve().parents[1] / "behaviours"
# the kinds a command line names (a world or a golden is named by a behaviour's folder), and their names' ends
_SUFFIXES = {"behaviour": (".yaml", ".yml"), "trace": (".csv",)}
_LISTED = 200  # the most names of a folder a hint reads: a folder of thousands is not listed whole


def _names(folder: Path, suffixes: tuple[str, ...]) -> list[str]:
    """The names of up to ``_LISTED`` files in ``folder`` ending in one of ``suffixes`` (none when it
    cannot be read), sorted."""
    try:
        with os.scandir(folder) as entries:
            names = [e.name for _, e in zip(range(_LISTED * 10), entries)
                     if e.name.endswith(suffixes) and not e.name.startswith(".")]
    except OSError:
        return []
    return sorted(names)[:_LISTED]


def missing_notes(path: str | Path, kind: str) -> tuple[str, ...]:
    """What to try when ``path`` does not exist: the files beside it with a close name, and for a
    behaviour the labs (``labsim labs``)."""
    p = Path(path)
    suffixes = _SUFFIXES.get(kind, ())
    notes = []
    if suffixes:
        close = difflib.get_close_matches(p.name, _names(p.parent, suffixes), n=1, cutoff=0.6)
        if close:
            notes.append(f"did you mean {p.parent / close[0]}?")
    if kind == "behaviour":
        labs = [Path(n).stem for n in _names(SHIPPED_LABS, (".yaml",))]
        lab = difflib.get_close_matches(p.stem, labs, n=1, cutoff=0.6)
        notes.append(f"labsim labs lists the labs labsim ships; a lab is given by its name: {lab[0]}" if lab else
                     "labsim labs lists the labs labsim ships; a lab's name works wherever a file does "
                     "(labsim run wall_follow)")
    elif kind == "trace":
        notes.append("a trace is what labsim run FILE --trace PATH writes")
    return tuple(notes)


def folder_notes(path: str | Path, kind: str) -> tuple[str, ...]:
    """What to give instead of a folder: the files of the kind asked for in it."""
    suffixes = _SUFFIXES.get(kind)
    if suffixes is None:
        return ()
    names = _names(Path(path), suffixes)
    shown = ", ".join(names[:5]) + (f" and {len(names) - 5} more" if len(names) > 5 else "")
    inside = f"; in it: {shown}" if names else f"; it holds no {' or '.join(suffixes)} file"
    notes = [f"give one {kind} file, not a folder{inside}"]
    if kind == "behaviour":
        notes.append("labsim test FOLDER checks every behaviour of a folder against its golden trace")
    return tuple(notes)
