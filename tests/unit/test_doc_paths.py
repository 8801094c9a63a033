"""Every test file, benchmark and module path the docs and docstrings name exists.

A path in prose is a promise to a reader: a test moved to its tier folder, or a module split,
leaves the sentence that names it pointing at nothing unless something checks it.
"""
from __future__ import annotations

import re
from pathlib import Path

from helpers import ROOT

# a path the repository holds, as prose names it: tests/..., benchmarks/..., a package folder's module
PATH = re.compile(r"\b((?:tests|benchmarks|foundation|dsl|runtime|backends|docs)/[A-Za-z0-9_/.-]+\.(?:py|md|yaml))\b")
PROSE = ["README.md", "docs/*.md", "*.py", "foundation/**/*.py", "dsl/**/*.py", "runtime/**/*.py", "backends/**/*.py",
         "benchmarks/*.py", "tests/**/*.py"]
# a path named as an example of what does not exist, or only in a trace's header
NOT_PATHS = {"tests/helpers.local_cluster"}


def named_paths() -> dict[str, set[str]]:
    out: dict[str, set[str]] = {}
    for pattern in PROSE:
        for file in ROOT.glob(pattern):
            if file.resolve() == Path(__file__).resolve():
                continue  # its own examples
            text = file.read_text(encoding="utf-8")
            for line_no, line in enumerate(text.splitlines(), 1):
                for m in PATH.finditer(line):
                    out.setdefault(m.group(1), set()).add(f"{file.relative_to(ROOT).as_posix()}:{line_no}")
    return out


def test_every_path_the_docs_name_exists() -> None:
    stale = sorted(f"{path} (named at {', '.join(sorted(where))})" for path, where in named_paths().items()
                   if path not in NOT_PATHS and not (ROOT / path).exists())
    assert stale == []


def test_the_check_finds_a_stale_path(tmp_path: Path) -> None:
    assert PATH.findall("see tests/test_kinds.py and runtime/run.py.") == ["tests/test_kinds.py", "runtime/run.py"]
