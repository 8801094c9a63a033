"""What kind of labsim file a path holds: behaviour, world, assignment, trace or golden, by one rule.

Every command that must tell the kinds apart asks here: ``labsim view`` (a trace to replay or
a behaviour to run), ``labsim test FOLDER`` and the pytest plugin (which YAML files are
behaviours), the behaviour reader (a world file given where a behaviour belongs) and shell
completion (which names to offer). A file says what it is by what it starts with or by its
top-level keys, never by its name alone: a trace starts with ``TRACE_MAGIC``; a YAML file's
version key (``labsim-world:``, ``labsim-assignment:`` or ``labsim:``) decides, and without one, keys only a behaviour
has or keys only a world has. A golden is a trace named ``NAME.golden.csv``, beside its
behaviour ``NAME.yaml``. Names (``YAML_SUFFIXES``, ``TRACE_SUFFIX``) only say which files are
worth looking at. Only text is needed, so this sits in the foundation, and a file is read
through the one way in (``labsim.foundation.files``), its first bytes only.
"""
from __future__ import annotations

from collections.abc import Collection
from pathlib import Path
from typing import Literal

from labsim.foundation.diagnostics import LabsimError
from labsim.foundation.files import MIB, read_head

Kind = Literal["behaviour", "world", "assignment", "trace", "golden", "unknown"]

TRACE_MAGIC = "# labsim-trace "  # a trace's first line starts so (docs/trace-format.md)
YAML_SUFFIXES = (".yaml", ".yml")  # behaviour and world files
TRACE_SUFFIX = ".csv"
GOLDEN_SUFFIX = ".golden.csv"
WORLD_VERSION_KEY = "labsim-world"
ASSIGNMENT_VERSION_KEY = "labsim-assignment"  # a grader's assignment file (docs/grading.md)
# keys only one kind of file has (the readers' key tables: dsl/syntax/read.py TOP_KEYS and
# backends/scene/world_file.py KEYS; tests/unit/test_kinds.py holds them to it)
BEHAVIOUR_ONLY_KEYS = frozenset({"labsim", "rules", "stop", "bind"})
WORLD_ONLY_KEYS = frozenset({"labsim-world", "bounds", "wall_thickness", "wall_height", "walls", "blocks", "spawns",
                             "ground", "mechanism"})
HEAD_BYTES = MIB  # the most a behaviour or world file may be: its keys are all in there


def kind_of_keys(keys: Collection[str]) -> Kind:
    """What a YAML mapping's top-level keys say it is: its version key first, then the keys
    only one kind has (a world file without its version key is still a world file)."""
    if WORLD_VERSION_KEY in keys:
        return "world"
    if ASSIGNMENT_VERSION_KEY in keys:
        return "assignment"
    if any(k in BEHAVIOUR_ONLY_KEYS for k in keys):
        return "behaviour"
    if any(k in WORLD_ONLY_KEYS for k in keys):
        return "world"
    return "unknown"


def kind_of_text(text: str, name: str = "") -> Kind:
    """What a file's text (or its beginning) says it is; ``name`` tells a golden from a trace."""
    if text.lstrip("\ufeff").startswith(TRACE_MAGIC):
        return "golden" if is_golden_name(name) else "trace"
    return kind_of_keys(top_level_keys(text))


def file_kind(path: str | Path) -> Kind:
    """What the file at path is; "unknown" for a file that cannot be read (the reader that
    reads it whole then says why, in the words of the one way in)."""
    try:
        head = read_head(path, HEAD_BYTES)
    except LabsimError:
        return "unknown"
    return kind_of_text(head.decode("utf-8", "replace"), str(path))


def is_golden_name(path: str | Path) -> bool:
    return str(path).endswith(GOLDEN_SUFFIX)


def golden_path(behaviour: str | Path) -> Path:
    """The golden trace beside a behaviour file: ``NAME.golden.csv`` for ``NAME.yaml``."""
    p = Path(behaviour)
    return p.with_name(p.name.rsplit(".", 1)[0] + GOLDEN_SUFFIX)


def top_level_keys(text: str) -> set[str]:
    """The keys of a YAML document's top-level block mapping, from its text: each line at the
    first column that is no comment, no list item and no document marker, up to its colon.
    A sniff, not a parse (a flow mapping at the top says nothing); the readers parse."""
    keys: set[str] = set()
    for line in text.splitlines():
        if not line or line[0] in " \t#-%{[?:" or ":" not in line:
            continue
        key = line.split(":", 1)[0].rstrip()
        if len(key) >= 2 and key[0] == key[-1] and key[0] in "'\"":
            key = key[1:-1]
        keys.add(key)
    return keys
