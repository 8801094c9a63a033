"""Shared helpers: paths, fixture expectations, a tiny in-memory behaviour writer."""
from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
FIXTURES = Path(__file__).resolve().parent / "fixtures"
BEHAVIOURS = ROOT / "behaviours"


def expectations(path: Path) -> set[tuple[int, int, str]]:
    """The `# expect: LINE:COL: message` (or `# expect: -: message`) lines of a fixture."""
    out = set()
    for line in path.read_text().splitlines():
        m = re.match(r"# expect: (?:(\d+):(\d+)|-): (.*)$", line)
        if m:
            out.add((int(m.group(1) or 0), int(m.group(2) or 0), m.group(3)))
    return out


@pytest.fixture
def write(tmp_path: Path):
    """write(text, name='b.yaml') -> path of a new file holding text."""
    def _write(text: str, name: str = "b.yaml") -> Path:
        p = tmp_path / name
        p.write_text(text)
        return p
    return _write
