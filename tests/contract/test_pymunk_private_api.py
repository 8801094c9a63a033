"""The part of pymunk labsim uses that is not pymunk's public API, named, on the pymunk installed.

backends/pymunk/chipmunk.py calls chipmunk's C functions through ``pymunk._chipmunk_cffi`` and
reaches the C objects behind pymunk's through ``Body._body``, ``Space._space`` and
``Constraint._constraint``. pymunk may change any of these in a release without notice, so
pyproject.toml bounds pymunk to the releases the goldens were checked on; these tests say which
piece a newer (or older) pymunk lacks, rather than a run failing on it. The C functions and
structs are read from chipmunk.py itself, so a new one there is checked here without an edit.
"""
from __future__ import annotations

import importlib.metadata
import re
import sys

import pytest
from helpers import ROOT

CHIPMUNK = ROOT / "backends" / "pymunk" / "chipmunk.py"
tomllib = pytest.importorskip("tomllib" if sys.version_info >= (3, 11) else "tomli")


def release(text: str) -> tuple[int, ...]:
    return tuple(int(part) for part in re.findall(r"\d+", text)[:3])


def bound() -> tuple[str, str]:
    """pyproject.toml's ``pymunk>=LOW,<HIGH``."""
    deps = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]["dependencies"]
    (spec,) = [d for d in deps if d.startswith("pymunk")]
    match = re.fullmatch(r"pymunk>=([\d.]+),<([\d.]+)", spec.replace(" ", ""))
    assert match, f"pymunk must be bounded on both sides in pyproject.toml (it uses a private API): {spec!r}"
    return match.group(1), match.group(2)


def test_the_installed_pymunk_is_one_labsim_is_tested_with() -> None:
    low, high = bound()
    installed = importlib.metadata.version("pymunk")
    assert release(low) <= release(installed) < release(high), (
        f"pymunk {installed} is outside pymunk>={low},<{high}, the releases labsim's goldens were checked on; "
        "labsim uses pymunk's private pymunk._chipmunk_cffi (backends/pymunk/chipmunk.py)")


def test_chipmunks_functions_and_structs_are_where_labsim_calls_them() -> None:
    from pymunk._chipmunk_cffi import ffi, lib

    source = CHIPMUNK.read_text(encoding="utf-8")
    functions = sorted(set(re.findall(r"\blib\.(cp\w+)", source)))
    structs = sorted(set(re.findall(r'\bffi\.(?:new|callback)\("(cp\w+)', source)))
    assert len(functions) >= 10 and len(structs) >= 3, "chipmunk.py no longer reads as this test expects"
    assert [f for f in functions if not hasattr(lib, f)] == [], "chipmunk functions pymunk._chipmunk_cffi lacks"
    missing = []
    for struct in structs:
        try:
            ffi.typeof(struct if struct.endswith("Func") else struct + " *")
        except (ffi.error, TypeError) as e:
            missing.append(f"{struct}: {e}")
    assert missing == [], "C types pymunk._chipmunk_cffi's ffi does not know"
    # the fields the generated sense() and the lidar read from the result structs
    info = ffi.new("cpSegmentQueryInfo *")
    assert (info.alpha, info.normal.x, info.normal.y) == (0.0, 0.0, 0.0)
    assert ffi.new("cpPointQueryInfo *").distance == 0.0


def test_the_c_objects_behind_pymunks_are_where_labsim_reaches_them() -> None:
    import pymunk

    body = pymunk.Body(1.0, 1.0)
    space = pymunk.Space()
    joint = pymunk.PinJoint(body, pymunk.Body(body_type=pymunk.Body.STATIC))
    for obj, attribute in ((body, "_body"), (space, "_space"), (joint, "_constraint")):
        assert hasattr(obj, attribute), f"pymunk.{type(obj).__name__} has no {attribute} (backends/pymunk/chipmunk.py)"

    from pymunk._chipmunk_cffi import lib

    lib.cpBodySetPosition(body._body, (1.5, -2.0))
    assert tuple(body.position) == (1.5, -2.0)
