"""Every file labsim reads goes through the one way in, ``foundation/files.py`` (docs/security.md).

There, a file is opened without blocking, must be a regular file and is measured before a
byte is read, and the operating system's refusals become a diagnostic; a bare ``open()``
elsewhere waits forever on a FIFO, reads ``/dev/zero`` until memory runs out and lets a
traceback through. ``labsim serve``'s ``sim.createTexture`` opened a client's path so. This
test scans the package's syntax trees for the calls that read a file around the one way in
and fails on any that is not on ``ALLOWED``, each with the reason it is safe:

* the builtin ``open(...)``, ``io.open(...)`` and ``os.open(...)``;
* ``X.read_text(...)`` and ``X.read_bytes(...)`` (``pathlib.Path``'s; the one way in's own
  ``read_text`` is called by name);
* ``np.load``, ``np.fromfile``, ``np.loadtxt``, ``np.genfromtxt`` and ``cv2.imread``.

Like tests/hostile/test_user_text_sinks.py it flags a call by its shape, so ``Path.open()`` (which
cannot be told from a backend's ``open()`` by shape) is not caught: a reviewer's eye is.
"""
from __future__ import annotations

import ast
from pathlib import Path

from helpers import PACKAGE_DIRS, ROOT

ONE_WAY_IN = "foundation/files.py"
OPENERS = {("io", "open"), ("os", "open")}
LOADERS = {("np", "load"), ("numpy", "load"), ("np", "fromfile"), ("np", "loadtxt"), ("np", "genfromtxt"),
           ("cv2", "imread")}
PATH_READS = {"read_text", "read_bytes"}

# (file, the flagged call as ast.unparse writes it) -> why it is safe
ALLOWED: dict[tuple[str, str], str] = {
    ("runtime/trace.py", "open(self._out.partial, 'rb')"):
        "the trace this run is writing, read back (its last 64 KiB) to count its ticks: labsim's own "
        "regular file, made by Output",
    ("runtime/cli/main.py", "os.open(os.devnull, os.O_WRONLY)"):
        "the null device, opened for writing after a broken pipe: no file is read",
    ("backends/pymunk/camera.py", "Path(__file__).read_bytes()"):
        "labsim's own source file, hashed to name a cache entry",
    ("foundation/memory.py", "open('/proc/self/statm', encoding='ascii')"):
        "the kernel's count of this process's pages, read to set the run's memory cap: no user path",
    ("backends/pymunk/camera.py", "np.load(path, allow_pickle=False)"):
        "a ground drawing in the user's own cache folder (foundation/cache.py), without pickles; a "
        "damaged entry is drawn again",
}


def _package_files() -> list[Path]:
    files = sorted(ROOT.glob("*.py"))
    for folder in PACKAGE_DIRS:
        files += sorted((ROOT / folder).rglob("*.py"))
    return files


def _reads(tree: ast.AST) -> list[ast.Call]:
    found = []
    for node in ast.walk(tree):
        if not isinstance(node, ast.Call):
            continue
        f = node.func
        if isinstance(f, ast.Name) and f.id == "open":
            found.append(node)
        elif isinstance(f, ast.Attribute):
            owner = f.value.id if isinstance(f.value, ast.Name) else ""
            if (owner, f.attr) in OPENERS | LOADERS or f.attr in PATH_READS:
                found.append(node)
    return found


def test_every_read_goes_through_the_one_way_in() -> None:
    flagged = set()
    for path in _package_files():
        rel = path.relative_to(ROOT).as_posix()
        if rel == ONE_WAY_IN:
            continue
        for call in _reads(ast.parse(path.read_text(encoding="utf-8"), rel)):
            flagged.add((rel, ast.unparse(call)))
    unexplained = sorted(flagged - set(ALLOWED))
    assert not unexplained, ("files read around foundation/files.py (use read_input/read_text/read_served, or "
                             f"add the call to ALLOWED with the reason it is safe): {unexplained}")
    assert not set(ALLOWED) - flagged, f"ALLOWED lists calls that are gone: {sorted(set(ALLOWED) - flagged)}"


def test_the_scan_sees_what_it_is_for() -> None:
    bare = ("def f(p, name):\n    with open(name, 'rb') as f:\n        return f.read()\n"
            "def g(p):\n    return Path(p).read_text() + Path(p).read_bytes().decode() + str(np.load(p))\n"
            "def h(p):\n    return io.open(p), os.open(p, 0), cv2.imread(p), read_text(p, 'behaviour')\n")
    shapes = sorted(ast.unparse(c) for c in _reads(ast.parse(bare)))
    assert shapes == sorted(["open(name, 'rb')", "Path(p).read_text()", "Path(p).read_bytes()", "np.load(p)",
                             "io.open(p)", "os.open(p, 0)", "cv2.imread(p)"])
