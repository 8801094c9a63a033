"""The command outputs the README and the docs quote are what the commands print today.

docs/regenerate.py holds a recipe per quoted output; here each is run and compared with every
block that quotes it, numbers to the precision printed (a run's wall time and real-time factor
apart). When one fails, run ``python docs/regenerate.py`` and commit the docs it rewrote.
"""
from __future__ import annotations

import importlib.util
import sys

import pytest
from helpers import DOCS

_spec = importlib.util.spec_from_file_location("regenerate", DOCS / "regenerate.py")
assert _spec is not None and _spec.loader is not None
regenerate = importlib.util.module_from_spec(_spec)
sys.modules.setdefault("regenerate", regenerate)  # its dataclasses look their module up there
_spec.loader.exec_module(regenerate)


def test_every_quoted_output_names_a_recipe_and_every_recipe_is_quoted() -> None:
    assert regenerate.unmatched() == []
    found = regenerate.blocks()
    assert [f"{b.path.name}: {b.name}" for b in found if b.name not in regenerate.RECIPES] == []
    assert set(regenerate.RECIPES) <= {b.name for b in found}


def test_a_changed_number_is_a_difference_and_the_wall_time_is_not() -> None:
    quoted = "  done: 30000 ticks, 1500.00 s simulated in 2.38 s (631x real time)\n  near_misses  936\n"
    assert regenerate.differences(quoted, quoted.replace("2.38 s (631x", "9.10 s (1,204x")) == []
    assert regenerate.differences(quoted, quoted.replace("  936", "  937")) == [
        "line 2: '  near_misses  936' | '  near_misses  937'"]
    assert regenerate.differences(quoted, quoted.replace("  936", "   936")) == []  # alignment only
    assert regenerate.differences(quoted, quoted + "  one more\n") == ["2 lines quoted, 3 printed"]


def test_a_marker_without_its_block_is_found(tmp_path) -> None:
    doc = tmp_path / "x.md"
    doc.write_text("<!-- output: wall-sweep -->\n```\nold\n```\n<!-- end output -->\n<!-- output: wall-summary -->\n")
    assert len(regenerate.blocks([doc])) == 1
    assert regenerate.unmatched([doc]) == [f"{doc}: 2 output markers, 1 well-formed blocks "
                                           "(<!-- output: NAME -->, a fenced block, <!-- end output -->)"]


@pytest.mark.slow  # each runs its lab: the sweep runs 40 of them (-m long)
@pytest.mark.parametrize("name", [pytest.param(n, marks=pytest.mark.long) if n in regenerate.LONG else n
                                  for n in regenerate.RECIPES])
def test_the_quoted_output_is_what_the_command_prints(name: str) -> None:
    printed = regenerate.RECIPES[name].text()
    quoted = [b for b in regenerate.blocks() if b.name == name]
    problems = [f"{b.path.name}: {d}" for b in quoted for d in regenerate.differences(b.body, printed)]
    assert problems == [], f"python docs/regenerate.py {name} writes what the command prints now"
