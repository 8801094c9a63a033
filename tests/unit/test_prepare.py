"""A file compiled once for several seeds (``labsim.dsl.compile.prepare``, as a grader's runs are)
is the same Program, field by field, as each seed's own ``compile_file``, and the same errors."""
from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest
from helpers import BEHAVIOURS, FIXTURES

import labsim.dsl.compile as compiling
from labsim.dsl.compile import compile_file, prepare
from labsim.dsl.emit.program import Program
from labsim.foundation.diagnostics import LabsimError

SEEDS = (0, 1, 7, 2**53)
# every file that compiles: the labs, and fixtures with warnings, random placement and noise
FILES = [*sorted(BEHAVIOURS.glob("*.yaml")), FIXTURES / "language_12.yaml", FIXTURES / "noise.yaml",
         FIXTURES / "grading" / "reference.yaml", FIXTURES / "pid_inf_with_warning.yaml",
         FIXTURES / "equality_with_warning.yaml"]


def fields(program: Program) -> dict[str, object]:
    out = {f.name: getattr(program, f.name) for f in dataclasses.fields(program)}
    code = out.pop("code")
    out["code"] = (code.source, code.compiled, code.sites, code.functions)  # type: ignore[attr-defined]
    return out


@pytest.mark.parametrize("path", FILES, ids=lambda p: p.name)
def test_each_seed_of_a_prepared_file_is_that_seeds_compile(path: Path) -> None:
    prepared = prepare(path)
    for seed in (*SEEDS, None):
        assert fields(prepared.program(seed)) == fields(compile_file(path, seed=seed))


def test_overrides_are_part_of_what_is_prepared() -> None:
    path = BEHAVIOURS / "wall_follow.yaml"
    prepared = prepare(path, {"front": "0.9"})
    assert fields(prepared.program(4)) == fields(compile_file(path, {"front": "0.9"}, seed=4))
    assert prepared.program(4).params["front"] == 0.9


def test_a_prepared_file_is_generated_once_for_all_its_seeds(monkeypatch) -> None:
    calls = []
    real = compiling.generate
    monkeypatch.setattr(compiling, "generate", lambda *a: calls.append(a) or real(*a))
    prepared = prepare(BEHAVIOURS / "wall_follow.yaml")
    programs = [prepared.program(seed) for seed in SEEDS]
    assert len(calls) == 1
    assert len({id(p.code) for p in programs}) == 1  # one code for all, each run binds its own
    assert [p.seed for p in programs] == list(SEEDS)


def test_random_places_differ_by_seed_as_they_do_compiled_alone() -> None:
    prepared = prepare(FIXTURES / "language_12.yaml")
    starts = {seed: prepared.program(seed).starts for seed in SEEDS}
    assert len(set(starts.values())) == len(SEEDS)
    assert starts == {seed: compile_file(FIXTURES / "language_12.yaml", seed=seed).starts for seed in SEEDS}


def errors(call) -> list[str]:
    with pytest.raises(LabsimError) as e:
        call()
    return [d.format() for d in e.value.diagnostics]


def test_errors_are_the_same_as_compile_files() -> None:
    # an error of the file raises when it is prepared; crowding and strict warnings, for each seed
    broken = FIXTURES / "arity_with_error.yaml"
    assert errors(lambda: prepare(broken)) == errors(lambda: compile_file(broken))
    crowd = FIXTURES / "crowd_with_error.yaml"
    prepared = prepare(crowd)
    assert errors(lambda: prepared.program(3)) == errors(lambda: compile_file(crowd, seed=3))
    warned = FIXTURES / "equality_with_warning.yaml"
    strict = prepare(warned, strict=True)
    assert errors(lambda: strict.program(1)) == errors(lambda: compile_file(warned, seed=1, strict=True))
    assert errors(lambda: strict.program(-1)) == errors(lambda: compile_file(warned, seed=-1))
