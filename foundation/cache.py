"""Where labsim keeps what it can rebuild: the user's cache folder, or nothing.

Two things are worth keeping between processes: the expression grammar's parse tables
(``labsim.dsl.syntax.parse``, 60-70 ms to build) and a world's ground drawn as a texture
(``labsim.backends.pymunk.camera``, a quarter of a second for the road loop). Both go to
one folder of the user's own: ``$LABSIM_CACHE_DIR`` if set, else the platform's cache
folder (``$XDG_CACHE_HOME`` or ``~/.cache`` on Linux, ``~/Library/Caches`` on macOS,
``%LOCALAPPDATA%`` on Windows) under ``labsim``. Not the installed package, which may be
read-only, and not the shared temporary folder, where another user could plant a file.
A cache is only ever a shortcut: when the folder cannot be made or written (a read-only
home, a full disk), labsim builds what it needs and carries on, and every entry is keyed
by what it was built from, so a stale one is never used.
"""
from __future__ import annotations

import contextlib
import os
import sys
import tempfile
from pathlib import Path


def cache_dir() -> Path | None:
    """labsim's cache folder, made (private to the user) if need be; None when it cannot be."""
    chosen = os.environ.get("LABSIM_CACHE_DIR")
    if chosen:
        folder = Path(chosen)
    else:
        if sys.platform == "win32":
            base = os.environ.get("LOCALAPPDATA") or str(Path.home() / "AppData" / "Local")
        elif sys.platform == "darwin":
            base = str(Path.home() / "Library" / "Caches")
        else:
            base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
        folder = Path(base) / "labsim"
    try:
        folder.mkdir(mode=0o700, parents=True, exist_ok=True)
    except (OSError, RuntimeError):  # RuntimeError: no home folder to expand
        return None
    return folder if os.access(folder, os.W_OK | os.X_OK) else None


def write_atomically(path: Path, data: bytes) -> bool:
    """Write data to path through a temporary file in the same folder, so that a reader in
    another process sees the whole file or none; False when it cannot be written."""
    try:
        fd, temporary = tempfile.mkstemp(dir=path.parent, prefix=path.name, suffix=".part")
    except OSError:
        return False
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        os.replace(temporary, path)
        return True
    except OSError:
        with contextlib.suppress(OSError):
            os.unlink(temporary)
        return False
