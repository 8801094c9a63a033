"""One way in and one way out for every file labsim reads or writes (docs/security.md).

labsim runs files it did not write: a class's behaviours on a teacher's machine, a trace a
student sends back. Every file it reads goes through ``read_input``: it must be a regular file
(a FIFO would block, ``/dev/zero`` never ends, a folder is no file), it is measured before a
byte is read, and whatever the operating system says (a name too long, a folder the user may
not enter) becomes one diagnostic in the user's words, never a traceback. Every file it writes
goes through ``check_output`` and ``Output``: never onto one of the run's inputs (compared by
inode, so a hard link is caught), never onto a device, and written beside the target under
another name and renamed into place once complete, so a failed write leaves the old file.

A behaviour names the files it reads (its world) relative to its own folder; ``policy_problem``
says when such a name reaches outside that folder, which is refused unless the folder it
reaches is allowed on the command line (``--allow-path``, kept in ``ALLOW_ENV`` so that a
sweep's worker processes see the same setting); the built-in worlds are the scene's to allow
(``labsim.backends.scene.world_names``). A client of ``labsim serve`` names files too (a
texture): ``served_problem`` keeps it to the folder the server started in, ``labsim scene``'s
scratch folders (``SCRATCH_PREFIX``) and the ``--allow-path`` folders.

This module belongs to the foundation and imports nothing of labsim beyond its diagnostics,
so the scene's readers, the language and the runtime all use it.
"""
from __future__ import annotations

import contextlib
import errno
import os
import stat
import tempfile
from collections.abc import Iterable, Iterator, Sequence
from pathlib import Path
from typing import Any, BinaryIO

from labsim.foundation.diagnostics import Diagnostic, LabsimError
from labsim.foundation.hints import folder_notes, missing_notes

KIB, MIB = 1 << 10, 1 << 20
# Each kind of file, the most labsim reads of it. Hand-written files stay far below 1 MiB (the
# largest shipped behaviour or world is under 10 KiB); a trace of 1 GiB holds about seven
# million rows, far past the trace budget of a run. Larger files are refused before reading.
# A texture a client of ``labsim serve`` names is at most what one request may carry (the
# server's ZMQ_MAXMSGSIZE, twice a 4K RGBA image).
MAX_BYTES = {"behaviour": MIB, "world": MIB, "mechanism": MIB, "trace": 1024 * MIB, "golden": 1024 * MIB,
             "texture": 64 * MIB}
DEFAULT_MAX_BYTES = MIB

ALLOW_ENV = "LABSIM_ALLOW_PATH"  # folders a behaviour may read outside its own, os.pathsep-separated

_KINDS = ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a FIFO (named pipe)"), (stat.S_ISCHR, "a device"),
          (stat.S_ISBLK, "a device"), (stat.S_ISSOCK, "a socket"))


def os_words(e: OSError) -> str:
    """What the operating system said, as words for a person: 'permission denied'."""
    text = e.strerror or (errno.errorcode.get(e.errno or 0, "") if e.errno else "") or str(e)
    return text[:1].lower() + text[1:]


def _not_regular(mode: int) -> str:
    return next((what for test, what in _KINDS if test(mode)), "not a regular file")


def _error(path: str | Path, message: str, notes: tuple[str, ...] = ()) -> LabsimError:
    return LabsimError([Diagnostic(str(path), message, notes=notes)])


@contextlib.contextmanager
def _opened(path: str | Path, kind: str) -> Iterator[tuple[int, os.stat_result]]:
    """A regular file's descriptor and status, or LabsimError saying in words why not.

    It is opened without blocking (a FIFO with no writer would wait forever) and inspected
    through the open descriptor (no window between the check and the read)."""
    flags = os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_NOCTTY", 0) | getattr(os, "O_CLOEXEC", 0)
    try:
        fd = os.open(path, flags)
    except FileNotFoundError:
        raise _error(path, f"no such {kind} file", missing_notes(path, kind)) from None
    except IsADirectoryError:
        raise _error(path, f"is a folder, not a {kind} file", folder_notes(path, kind)) from None
    except OSError as e:
        raise _error(path, f"cannot read the {kind} file: {os_words(e)}") from None
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode):
            what = _not_regular(info.st_mode)
            raise _error(path, f"is {what}, not a {kind} file", folder_notes(path, kind) if what == "a folder" else ())
        yield fd, info
    except OSError as e:
        raise _error(path, f"cannot read the {kind} file: {os_words(e)}") from None
    finally:
        os.close(fd)


def read_input(path: str | Path, kind: str = "behaviour", max_bytes: int | None = None) -> bytes:
    """A file's bytes, or LabsimError saying in words why not: checked before any read.

    Only a regular file (``_opened``) of at most ``max_bytes`` (default: ``MAX_BYTES[kind]``) is read."""
    limit = max_bytes if max_bytes is not None else MAX_BYTES.get(kind, DEFAULT_MAX_BYTES)
    with _opened(path, kind) as (fd, info):
        if info.st_size > limit:
            raise _error(path, f"file is {info.st_size / 1e6:.1f} MB; {kind} files are limited to {_size(limit)}")
        return _read_all(fd, path, kind, limit)


def read_chunks(path: str | Path, kind: str = "trace", size: int = 4 * MIB) -> Iterator[bytes]:
    """A file's bytes a chunk at a time, checked as ``read_input`` checks it (a regular file, at
    most ``MAX_BYTES[kind]``): for a reader that keeps less than the whole file."""
    limit = MAX_BYTES.get(kind, DEFAULT_MAX_BYTES)
    with _opened(path, kind) as (fd, info):
        if info.st_size > limit:
            raise _error(path, f"file is {info.st_size / 1e6:.1f} MB; {kind} files are limited to {_size(limit)}")
        total = 0
        while chunk := os.read(fd, min(limit + 1 - total, size)):
            total += len(chunk)
            if total > limit:
                raise _error(path, f"grew past {_size(limit)} while it was read; {kind} files are limited to that")
            yield chunk


def read_head(path: str | Path, size: int, kind: str = "labsim") -> bytes:
    """A file's first ``size`` bytes at most (what it starts with, to tell what kind of file it
    is), or LabsimError: a regular file only, as ``read_input``, whatever its length."""
    with _opened(path, kind) as (fd, _info):
        chunks: list[bytes] = []
        total = 0
        while total < size:
            chunk = os.read(fd, min(size - total, 4 * MIB))
            if not chunk:
                break
            chunks.append(chunk)
            total += len(chunk)
        return b"".join(chunks)


def _read_all(fd: int, path: str | Path, kind: str, limit: int) -> bytes:
    """Read to the end, but never past the limit (a file that grows while read)."""
    chunks: list[bytes] = []
    total = 0
    while True:
        chunk = os.read(fd, min(limit + 1 - total, 4 * MIB))
        if not chunk:
            return b"".join(chunks)
        chunks.append(chunk)
        total += len(chunk)
        if total > limit:
            raise _error(path, f"grew past {_size(limit)} while it was read; {kind} files are limited to that")


def _size(n: int) -> str:
    return f"{n // MIB} MiB" if n > MIB else f"{n // KIB} KiB" if n >= KIB else f"{n} bytes"


def read_text(path: str | Path, kind: str = "behaviour", max_bytes: int | None = None) -> str:
    """``read_input`` as UTF-8 text (without a byte-order mark); a binary file says where it stops being text."""
    data = read_input(path, kind, max_bytes)
    try:
        return data.decode("utf-8").lstrip("\ufeff")
    except UnicodeDecodeError as e:
        raise LabsimError([not_utf8(path, data, e.start, echo=kind == "behaviour")]) from None


SAVE_AS_UTF8 = "save the file as UTF-8 (most editors: File > Save with Encoding > UTF-8)"


def not_utf8(path: str | Path, data: bytes, at: int, echo: bool) -> Diagnostic:
    """The first byte that is not UTF-8, at its line and column (in characters of the line as
    far as it decodes, a byte-order mark not counted), and how to fix the file.

    Only a file that is the user's own (``echo``: a behaviour) has its line shown and the byte
    named: a world path may reach a private file, whose contents are never shown
    (docs/security.md, "What is echoed")."""
    start = data.rfind(b"\n", 0, at) + 1
    line = data.count(b"\n", 0, at) + 1
    before = data[start:at].decode("utf-8")
    if line == 1:
        before = before.lstrip("\ufeff")
    col = len(before) + 1
    if not echo:
        return Diagnostic(str(path), f"not UTF-8 text: {SAVE_AS_UTF8}", line, col)
    end = data.find(b"\n", at)
    shown = data[start:end if end >= 0 else len(data)].decode("utf-8", errors="replace").rstrip("\r")
    if line == 1:
        shown = shown.lstrip("\ufeff")
    if "\0" in shown:
        shown = ""  # UTF-16 or binary: no line a terminal could show
    byte = data[at]
    if data.startswith((b"\xff\xfe", b"\xfe\xff")):
        what = "this file is UTF-16 text"
    else:
        # the usual culprit: an editor that saved the file in Windows' own encoding; a 'é' there
        # is the one byte 0xE9, and Word's curly apostrophe 0x92
        guess = bytes([byte]).decode("cp1252", errors="replace")
        legacy = "Latin-1" if byte >= 0xA0 else "Windows-1252"
        what = f"byte 0x{byte:02X} is not UTF-8 text" + (
            f" (it reads as '{guess}' in {legacy})" if guess.isprintable() and guess != "\ufffd" else "")
    return Diagnostic(str(path), f"{what}: {SAVE_AS_UTF8}", line, col, 0, "error", shown)


# -- the access policy --------------------------------------------------------------------------

_ALLOWED_HERE: list[Path] = []  # folders allowed for a while in this process only (``allowing``)


def real_path(path: str | Path) -> Path:
    """Where a path really leads: absolute, every symbolic link followed in the order the
    operating system follows them (os.path.realpath), so ``d/../x`` with ``d`` a link is the
    ``x`` beside the link's target, not the one beside ``d``. RuntimeError for a loop of links.

    Never ``os.path.normpath`` first: it drops ``d/..`` by spelling alone, and the policy would
    then judge a file other than the one that is opened."""
    return Path(path).resolve()  # os.path.realpath, then a stat that reports a loop


def allowed_folders() -> list[Path]:
    """The folders ``--allow-path`` opened (through ``ALLOW_ENV``), resolved, and any ``allowing`` adds."""
    env = [_real_or_as_is(p) for p in os.environ.get(ALLOW_ENV, "").split(os.pathsep) if p]
    return env + list(_ALLOWED_HERE)


def _real_or_as_is(path: str | Path) -> Path:
    """``real_path``, or the absolute path as written when it is a loop (which then holds no file)."""
    try:
        return real_path(path)
    except (OSError, RuntimeError):
        return Path(os.path.abspath(path))


@contextlib.contextmanager
def allowing(folder: str | Path) -> Iterator[None]:
    """Allow a folder while a block runs (a sweep's worker, running files the sweep checked)."""
    entry = _real_or_as_is(folder)
    _ALLOWED_HERE.append(entry)
    try:
        yield
    finally:
        _ALLOWED_HERE.remove(entry)


def allow(folders: Iterable[str | Path]) -> None:
    """Add folders to the allowed ones, for this process and the processes it starts."""
    current = [p for p in os.environ.get(ALLOW_ENV, "").split(os.pathsep) if p]
    os.environ[ALLOW_ENV] = os.pathsep.join(current + [str(_real_or_as_is(f)) for f in folders])


def _inside(path: Path, folder: Path) -> bool:
    return path == folder or folder in path.parents


def policy_problem(name: str, base: Path, allowed: Sequence[Path] | None = None) -> str:
    """Why a file a behaviour names (``name``, relative to the behaviour's folder ``base``)
    may not be read, or '' when it may: the file it really is (``real_path``: links followed
    where they stand, ``..`` after them) must lie inside ``base`` (resolved too), or inside a
    folder the command line allowed. (The built-in worlds' files are allowed by the one rule
    for world names, ``labsim.backends.scene.world_names.find_world``.)"""
    folders = [_real_or_as_is(f) for f in (base, *(allowed if allowed is not None else allowed_folders()))]
    try:
        real = real_path(base / name)
    except (OSError, RuntimeError):  # a loop of links
        return "is a loop of symbolic links"
    if any(_inside(real, f) for f in folders):
        return ""
    if Path(name).is_absolute() or name.startswith("~"):
        return "is an absolute path, outside the behaviour's folder"
    if not _inside(Path(os.path.abspath(base / name)), Path(os.path.abspath(base))):
        return "leads out of the behaviour's folder ('..')"
    link = _first_link(base, name)
    if link and link != name:
        return f"leads out of the behaviour's folder through the symbolic link '{link}'"
    return "is a symbolic link to a file outside the behaviour's folder"


def _first_link(base: Path, name: str) -> str:
    """The first part of ``name`` (as written, from ``base``) that is a symbolic link, or ''."""
    parts = Path(name).parts
    for i in range(len(parts)):
        if os.path.islink(base.joinpath(*parts[:i + 1])):
            return "/".join(parts[:i + 1])
    return ""


def policy_notes() -> tuple[str, ...]:
    return ("a behaviour reads only built-in worlds and files in its own folder (subfolders too); "
            "to allow another folder, pass --allow-path DIR (docs/security.md)",)


# -- what a client of labsim serve may read -----------------------------------------------------

SCRATCH_PREFIX = "labsim-scene-"  # labsim scene's temporary folders, which labsim serve may read


def in_scratch_folder(real: Path) -> bool:
    """Whether a file (its path with links followed) lies right inside one of ``labsim scene``'s
    temporary folders: named so, in the temporary folder, owned by this user and writable by
    no one else (tempfile makes it so), so that no other user of the machine can plant one."""
    folder = real.parent
    if not folder.name.startswith(SCRATCH_PREFIX) or folder.parent != Path(tempfile.gettempdir()).resolve():
        return False
    try:
        info = os.stat(folder)
    except OSError:
        return False
    mine = not hasattr(os, "getuid") or info.st_uid == os.getuid()
    return mine and not info.st_mode & (stat.S_IWGRP | stat.S_IWOTH)


def served_problem(name: str, base: Path) -> str:
    """Why ``labsim serve`` may not read a file a client names (relative to ``base``, the folder
    the server started in), or '' when it may: once links are followed, it must lie inside
    ``base``, inside an ``--allow-path`` folder, or right inside a ``labsim scene`` scratch
    folder. A client is anyone who reaches the port (docs/security.md, "The server")."""
    try:
        real = real_path(base / name)
    except (OSError, RuntimeError):  # a loop of links
        return "is a loop of symbolic links"
    if any(_inside(real, f) for f in (_real_or_as_is(base), *allowed_folders())) or in_scratch_folder(real):
        return ""
    return ("is outside the folders labsim serve reads: the one it was started in, labsim scene's "
            "temporary folders and any --allow-path DIR (docs/security.md)")


def read_served(name: str, base: Path, kind: str) -> bytes:
    """A file a client of ``labsim serve`` names (relative to ``base``), read the one way in
    once ``served_problem`` allows it; LabsimError says why not."""
    refused = served_problem(name, base)
    if refused:
        raise _error(name, refused)
    return read_input(base / name, kind)


# -- the way out --------------------------------------------------------------------------------

def check_output(path: str | Path, inputs: Iterable[str | Path], option: str = "") -> None:
    """LabsimError unless ``path`` can be written as a new regular file that is none of ``inputs``.

    Inputs are compared by device and inode, so a hard link or another spelling of an input is
    caught; a device, FIFO or folder is refused before the run starts (labsim writes files)."""
    where = f"{option} {path}".strip()
    p = Path(path)
    try:
        info = os.stat(p)
    except FileNotFoundError:
        info = None
    except OSError as e:
        raise _error(where, f"cannot write there: {os_words(e)}") from None
    if info is not None:
        if not stat.S_ISREG(info.st_mode):
            what = _not_regular(info.st_mode)
            hint = "; give a file name such as run.csv" if stat.S_ISDIR(info.st_mode) else ""
            raise _error(where, f"is {what}; labsim writes regular files only{hint}")
        for i in inputs:
            if str(i) and _same_file(info, i):
                raise _error(where, f"would overwrite an input of this run ({i}, by this name or a "
                                    "link); give the output its own file, such as run.csv")
    parent = p.parent
    if not parent.is_dir():
        raise _error(where, f"folder '{parent}' does not exist")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise _error(where, f"cannot write in folder '{parent}': permission denied")


def _same_file(info: os.stat_result, other: str | Path) -> bool:
    try:
        o = os.stat(other)
    except OSError:
        return False
    return (o.st_dev, o.st_ino) == (info.st_dev, info.st_ino)


class Output:
    """A file written beside its target and renamed into place by ``commit``: readers of the
    target see the old file or the whole new one, never half of it.

    ``partial`` names the file being written; by default a hidden temporary name, or a fixed
    one (``run.csv.partial``) for a trace, which a person looks for after a killed run."""

    def __init__(self, path: str | Path, partial: str | Path | None = None):
        self.path = Path(path)
        try:
            if partial is None:
                fd, name = tempfile.mkstemp(prefix=f".{self.path.name}.", suffix=".tmp", dir=self.path.parent)
                self.partial = Path(name)
                self.file: BinaryIO = os.fdopen(fd, "wb")
            else:
                self.partial = Path(partial)
                # a fresh file: an old one (or a link planted under that name) is removed, not followed
                with contextlib.suppress(FileNotFoundError):
                    os.unlink(self.partial)
                flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0)
                self.file = os.fdopen(os.open(self.partial, flags, 0o666), "wb")
        except OSError as e:
            raise write_error(self.path, e) from None

    def commit(self) -> None:
        """Close and rename into place (with the permissions a new file gets)."""
        try:
            self.file.close()
            umask = os.umask(0)
            os.umask(umask)
            os.chmod(self.partial, 0o666 & ~umask)
            os.replace(self.partial, self.path)
        except OSError as e:
            self.discard()
            raise write_error(self.path, e) from None

    def discard(self) -> None:
        with contextlib.suppress(OSError):
            self.file.close()
        with contextlib.suppress(OSError):
            os.unlink(self.partial)


def write_error(path: str | Path, e: OSError) -> LabsimError:
    """An OSError while writing, in words: 'cannot write run.csv: no space left on device'."""
    return _error(path, f"cannot write {Path(path).name}: {os_words(e)}")


@contextlib.contextmanager
def written(path: str | Path) -> Iterator[BinaryIO]:
    """The file a block writes, beside ``path``, renamed into place when the block ends; removed
    when it raises (an OSError as ``write_error``'s words), so no half file is ever left."""
    out = Output(path)
    try:
        yield out.file
    except OSError as e:
        out.discard()
        raise write_error(path, e) from None
    except BaseException:
        out.discard()
        raise
    out.commit()


def write_output(path: str | Path, data: bytes | str, inputs: Iterable[str | Path] = (), option: str = "") -> None:
    """Write a whole file the one way out: checked, written beside it, renamed into place."""
    check_output(path, inputs, option)
    with written(path) as f:
        f.write(data.encode("utf-8") if isinstance(data, str) else data)


def write_new(path: str | Path, data: bytes) -> None:
    """Write a file that is not there yet, not even as a symbolic link (``labsim new``'s copies):
    created with O_EXCL and O_NOFOLLOW, so a link planted under the name, dangling or not, is
    never written through. LabsimError says why not."""
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_CLOEXEC", 0)
    if os.path.islink(path):  # O_EXCL refuses it too; this says so in words
        raise _error(path, "is a symbolic link; labsim writes no file through a link (remove it, or "
                           "give another folder)")
    try:
        fd = os.open(path, flags, 0o666)
    except FileExistsError:
        raise _error(path, "already exists") from None
    except OSError as e:
        raise write_error(path, e) from None
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
    except OSError as e:
        raise write_error(path, e) from None


def save_figure(fig: Any, path: Path, **options: Any) -> None:
    """A matplotlib figure the one way out: drawn into the file beside the target, then renamed."""
    with written(path) as f:
        fig.savefig(f, format=path.suffix.lstrip(".").lower() or "png", **options)
