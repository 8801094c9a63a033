"""The short fuzz profile: mutated and generated behaviour files raise only labsim's own errors.

Each input goes through compile (read, check, lint, generate) and a few ticks on the pymunk
backend with a trace and a summary (tests/fuzz_inputs.py); anything but a ``LabsimError`` or
``BackendError`` fails, and hypothesis shrinks the input to the smallest that does. Derandomized,
so that CI sees the same inputs on every run; ``LABSIM_FUZZ=long`` runs many more here, and
tests/fuzz_long.py runs the long profile (100,000 inputs) on several processes.
"""
from __future__ import annotations

import os
from pathlib import Path

import pytest
from fuzz_inputs import (
    check_sweep_options,
    generated,
    generated_12,
    generated_13,
    generated_13_robots,
    generated_member_wise,
    mutated,
    run_input,
    seeds,
    sweep_options,
)
from hypothesis import HealthCheck, given, settings

LONG = os.environ.get("LABSIM_FUZZ") == "long"
SHORT = settings(max_examples=5000 if LONG else 800, derandomize=True, database=None, deadline=None,
                 suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])


def test_the_seeds_are_the_shipped_behaviours_fixtures_and_worlds() -> None:
    names = {s.name for s in seeds()}
    assert {"wall_follow.yaml", "crane.yaml", "minimal.yaml", "walls_lab4.yaml", "pendulum_world.yaml"} <= names
    assert any(s.world for s in seeds()) and any(not s.world for s in seeds())


@pytest.mark.slow
@pytest.mark.long
def test_mutated_files_give_diagnostics_not_exceptions(tmp_path: Path) -> None:
    outcomes: list[str] = []

    @SHORT
    @given(mutated())
    def fuzz(item: tuple[str, bytes, bool]) -> None:
        _, data, world = item
        outcomes.append(run_input(tmp_path, data, world))

    fuzz()
    assert "error" in outcomes and "ran" in outcomes  # the mutations break files, and not all of them


@pytest.mark.slow
@pytest.mark.long
def test_files_generated_from_the_grammar_give_diagnostics_not_exceptions(tmp_path: Path) -> None:
    outcomes: list[str] = []

    @SHORT
    @given(generated())
    def fuzz(text: str) -> None:
        outcomes.append(run_input(tmp_path, text.encode()))

    fuzz()
    assert outcomes.count("ran") >= len(outcomes) // 10  # many reach generated code and run


@pytest.mark.slow
@pytest.mark.long
def test_files_whose_robots_read_each_other_and_talk_give_diagnostics_not_exceptions(tmp_path: Path) -> None:
    outcomes: list[str] = []

    @SHORT
    @given(generated_13_robots())
    def fuzz(text: str) -> None:
        outcomes.append(run_input(tmp_path, text.encode()))

    fuzz()
    assert outcomes.count("ran") >= len(outcomes) // 3  # most reach generated code and run


@pytest.mark.slow
@pytest.mark.long
def test_files_of_language_12_give_diagnostics_not_exceptions(tmp_path: Path) -> None:
    """Groups with parameters as places, functions over groups, list groups, signals that read
    themselves, 'when' rules logging with format fields (tests/fuzz_inputs.py, generated_12)."""
    outcomes: list[str] = []

    @SHORT
    @given(generated_12())
    def fuzz(text: str) -> None:
        outcomes.append(run_input(tmp_path, text.encode()))

    fuzz()
    assert outcomes.count("ran") >= len(outcomes) // 10  # many reach generated code and run


@pytest.mark.slow
@pytest.mark.long
def test_files_with_lists_starts_and_read_back_give_diagnostics_not_exceptions(tmp_path: Path) -> None:
    """List parameters of every shape indexed at places from the edges, len(), per-robot starts, the wheels
    and the start pose read back, and a --set of the list (tests/fuzz_inputs.py, generated_13)."""
    outcomes: list[str] = []

    @SHORT
    @given(generated_13())
    def fuzz(case: tuple[str, dict[str, str]]) -> None:
        outcomes.append(run_input(tmp_path, case[0].encode(), overrides=case[1]))

    fuzz()
    assert outcomes.count("ran") >= len(outcomes) // 10  # many reach generated code and run
def test_files_of_member_wise_calls_and_slices_give_diagnostics_not_exceptions(tmp_path: Path) -> None:
    """Built-ins given groups member by member, memory and random ones among them, and slices in
    and out of range (format 1.3; tests/fuzz_inputs.py, generated_member_wise)."""
    outcomes: list[str] = []

    @SHORT
    @given(generated_member_wise())
    def fuzz(text: str) -> None:
        outcomes.append(run_input(tmp_path, text.encode()))

    fuzz()
    assert "error" in outcomes and outcomes.count("ran") >= len(outcomes) // 40  # most are mistakes on purpose


@pytest.mark.slow
@pytest.mark.long
def test_a_sweeps_options_give_diagnostics_not_exceptions() -> None:
    """--set and --seeds as typed, ordinary to hostile: each refused with labsim's own message, or
    a grid of the size counted (docs/sweep.md, "Limits")."""
    outcomes: list[str] = []

    @SHORT
    @given(sweep_options())
    def fuzz(item: tuple[list[str], str | None]) -> None:
        outcomes.append(check_sweep_options(*item))

    fuzz()
    assert "error" in outcomes and "ok" in outcomes
