"""Thousands of rules or states: the generated code keeps its if/elif chains short.

Python's compiler recurses once per ``elif``; a state of 3,000 rules or a file of 3,000 states
overflowed it (a RecursionError out of ``labsim check``). The generator now splits a long state
into chains of ``CHAIN`` rules and dispatches many states through a tree of ranges; these tests
check that such files check and run, and that the split code picks the same rule, tick for
tick, as the plain chain does.
"""
from __future__ import annotations

import csv
import subprocess
import sys
from pathlib import Path

import pytest

import labsim
import labsim.dsl.emit.codegen
from labsim.dsl.compile import compile_file
from labsim.dsl.library.support import STATE

HEAD = "labsim: 1\nworld: walls_lab4\nrobots:\n  p: {model: pioneer_p3dx, at: [0, 0, 0]}\n"


def many_rules(n: int, step: int) -> str:
    """One state of ``n`` rules: on tick t the rule of index ``step * t + 5`` fires (0-based)."""
    rules = "".join(f"  - if tick * {step} + 5 <= {i} then move({i % 3})\n" for i in range(n - 1))
    return f"{HEAD}stop: tick >= {(n - 6) // step}\nrules:\n{rules}  - else stop()\n"


def many_states(n: int, jump: int) -> str:
    """``n`` states, state i going to state (i * jump + 5) mod n on the tick after it is entered."""
    states = "".join(f"  s{i}:\n    - if entered then move({i % 3})\n    - else goto s{(i * jump + 5) % n}\n"
                     for i in range(n))
    return f"{HEAD}stop: tick >= 60\nrules:\n{states}"


def trace(path: Path, tmp_path: Path) -> list[tuple[str, str]]:
    out = tmp_path / (path.stem + ".csv")
    labsim.run(path, trace=out)
    with out.open() as f:
        rows = csv.DictReader(line for line in f if not line.startswith("#"))
        return [(row["state"], row["rule"]) for row in rows]


def expected_states(n: int, jump: int, ticks: int) -> list[tuple[str, str]]:
    out, state = [], 0
    for _ in range(ticks // 2 + 1):
        out += [(f"s{state}", f"s{state}:1"), (f"s{state}", f"s{state}:2")]
        state = (state * jump + 5) % n
    return out[:ticks]  # the stopping tick has no row


@pytest.mark.slow
@pytest.mark.long
def test_3000_rules_check_and_run(tmp_path: Path) -> None:
    path = tmp_path / "rules.yaml"
    path.write_text(many_rules(3000, 71))
    proc = subprocess.run([sys.executable, "-m", "labsim", "check", str(path)], capture_output=True, text=True,
                          timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "Traceback" not in proc.stdout + proc.stderr
    rows = trace(path, tmp_path)
    assert [rule for _, rule in rows] == [f"main:{71 * t + 6}" for t in range(len(rows))]
    assert len(rows) == (3000 - 6) // 71  # the stopping tick has no row


@pytest.mark.slow
@pytest.mark.long
def test_3000_states_check_and_run(tmp_path: Path) -> None:
    path = tmp_path / "states.yaml"
    path.write_text(many_states(3000, 71))
    proc = subprocess.run([sys.executable, "-m", "labsim", "check", str(path)], capture_output=True, text=True,
                          timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "Traceback" not in proc.stdout + proc.stderr
    assert trace(path, tmp_path) == expected_states(3000, 71, 60)


def test_split_chains_pick_the_rule_the_plain_chain_picks(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """With chains of 3, 40 rules make 14 chains and 50 states a tree three levels deep."""
    rules, states = tmp_path / "rules.yaml", tmp_path / "states.yaml"
    rules.write_text(many_rules(40, 3))
    states.write_text(many_states(50, 7))
    plain = trace(rules, tmp_path), trace(states, tmp_path)
    assert plain[1] == expected_states(50, 7, 60)
    monkeypatch.setattr(labsim.dsl.emit.codegen, "CHAIN", 3)
    split = compile_file(states).code.source
    assert f"if v{STATE} < 27:" in split and f"    if v{STATE} < 9:" in split  # ranges of 27, then of 9
    assert (trace(rules, tmp_path), trace(states, tmp_path)) == plain
