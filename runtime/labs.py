"""The labs labsim ships: behaviour files a student runs by name, lists, and copies to edit.

The labs live in ``behaviours/`` beside the package's subpackages, in a checkout and in an
installed wheel alike (the wheel ships them as ``labsim/behaviours``). Each is a behaviour
file with its golden trace beside it (``NAME.yaml``, ``NAME.golden.csv``). The command line
resolves a behaviour argument through ``behaviour_path``: a file that exists is taken as it is,
otherwise a lab's name (``labsim run wall_follow``) names that lab's file. A trace of a lab
names the file where labsim was installed when it ran; ``shipped_behaviour`` finds the lab again
wherever this labsim is installed, for the pictures that read the behaviour file.
"""
from __future__ import annotations

import hashlib
import os
from dataclasses import dataclass
from pathlib import Path

import yaml

from labsim.foundation.diagnostics import Diagnostic, LabsimError, did_you_mean
from labsim.foundation.files import os_words, read_input, read_text, write_new
from labsim.foundation.kinds import golden_path

# runtime/labs.py -> the package root, beside this module's folder (not `labsim.__file__`: the
# package root lazily imports the API, which imports this module)
LABS_DIR = Path(__file__).resolve().parents[1] / "behaviours"
SCHEMA_FILE = "behaviour.schema.json"


@dataclass(frozen=True)
class Lab:
    name: str  # the file's stem: what `labsim run NAME` takes
    title: str  # the file's `name:`
    path: Path

    @property
    def golden(self) -> Path:
        return golden_path(self.path)


def labs() -> dict[str, Lab]:
    """The shipped labs by name, in name order."""
    out = {}
    for path in sorted(LABS_DIR.glob("*.yaml")):
        out[path.stem] = Lab(path.stem, _title(path), path)
    return out


def _title(path: Path) -> str:
    """A lab file's ``name:`` (its first line of that key), without reading the whole file as YAML."""
    for line in read_text(path, "behaviour").splitlines():
        if line.startswith("name:"):
            value = yaml.safe_load(line.partition(":")[2] or "''")
            return str(value) if value is not None else ""
    return ""


def behaviour_path(argument: str) -> Path:
    """The behaviour file a command-line argument names: a path, or the name of a lab.

    A path that does not exist and is no lab's name is returned as it is, so that the loader
    reports it as a missing file (with a did-you-mean for a misspelt lab name when the
    argument looks like one).
    """
    path = Path(argument)
    if os.path.exists(argument) or path.suffix or "/" in argument or "\\" in argument:
        return path
    known = labs()
    if argument in known:
        return known[argument].path
    raise LabsimError([Diagnostic(argument, f"no such behaviour file or lab '{argument}'"
                                  f"{did_you_mean(argument, known)}",
                                  notes=("labs: " + ", ".join(known) + " (labsim labs lists them)",))])


def shipped_behaviour(named: str, sha256: str) -> Path | None:
    """The lab file of this labsim that a trace's header names (its ``behaviour`` and ``sha256``),
    or None when it names none of them.

    It is the lab when the named path is one of ``LABS_DIR``'s files (relative to the current
    folder, as a golden names it), or when a lab file's content has the header's hash: a lab run
    by name on another machine or another install, whose path is not this one. A file of a lab's
    name with other content is not the lab (another labsim's lab may read other columns); with
    no hash in the header, a lab's name in a ``behaviours`` folder is taken at its word.
    """
    path = Path(named)
    try:
        real = path.resolve() if named else None
    except (OSError, RuntimeError):  # a loop of links is no lab
        real = None
    known = labs()
    if real is not None and real.parent == LABS_DIR and real.stem in known and real == known[real.stem].path:
        return real
    if sha256:
        return next((lab.path for lab in known.values() if _sha256(lab.path) == sha256), None)
    if path.parent.name == LABS_DIR.name and path.suffix == ".yaml" and path.stem in known:
        return known[path.stem].path
    return None


def _sha256(path: Path) -> str:
    """A behaviour file's hash as the compiler takes it (``labsim.dsl.syntax.read``): of its text."""
    try:
        return hashlib.sha256(read_text(path, "behaviour").encode()).hexdigest()
    except LabsimError:
        return ""


def copy_lab(name: str, folder: Path) -> list[Path]:
    """Copy a lab's behaviour file and its golden trace into folder (made if missing), with the
    behaviour schema its first line names, unless the folder has it already.

    Refuses to overwrite: a student's edited copy is never lost to a second ``labsim new``.
    """
    known = labs()
    if name not in known:
        raise LabsimError([Diagnostic(name, f"no lab '{name}'{did_you_mean(name, known)}",
                                      notes=("labs: " + ", ".join(known),))])
    lab = known[name]
    sources = [p for p in (lab.path, lab.golden) if p.exists()]
    targets = [folder / p.name for p in sources]
    _refuse_targets(folder, targets)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise LabsimError([Diagnostic(str(folder), f"cannot write there: {os_words(e)}")]) from None
    for source, target in zip(sources, targets):  # never through a link planted there since
        write_new(target, read_input(source, "golden" if source == lab.golden else "behaviour"))
    schema = LABS_DIR / SCHEMA_FILE  # what the lab's first line points editors at
    # a schema there already, or a link by that name (even one to nothing), is left as it is
    if schema.exists() and not os.path.lexists(folder / SCHEMA_FILE):
        write_new(folder / SCHEMA_FILE, read_input(schema, "schema"))
        targets.append(folder / SCHEMA_FILE)
    return targets


def _refuse_targets(folder: Path, targets: list[Path]) -> None:
    """LabsimError when a copy would overwrite a file or write through a symbolic link (dangling
    or not: a link to nothing would create its target wherever it points), or the folder is no folder."""
    for t in targets:
        if os.path.islink(t):
            raise LabsimError([Diagnostic(str(t), "is a symbolic link; labsim new writes no file through a "
                                          "link (remove it, or give another folder)")])
    existing = [t for t in targets if t.exists()]
    if existing:
        raise LabsimError([Diagnostic(str(existing[0]), "already exists; labsim new does not overwrite "
                                      "files (give another folder, or remove it first)")])
    if os.path.islink(folder) and not folder.exists():
        raise LabsimError([Diagnostic(str(folder), f"is a symbolic link to '{os.readlink(folder)}', which "
                                      "does not exist; labsim new writes no file through a link")])
    if folder.exists() and not folder.is_dir():
        raise LabsimError([Diagnostic(str(folder), "is a file, not a folder")])
