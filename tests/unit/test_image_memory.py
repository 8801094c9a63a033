"""A tick's image memory (dsl/analysis/image_memory.py, dsl/analysis/budget.py) and the operating system's cap
(foundation/memory.py): which image signals are kept, where each is freed, the estimate, and a
cap that is put back after the run."""
from __future__ import annotations

import resource
from pathlib import Path

import pytest

from labsim.backends import load_backend
from labsim.dsl.compile import compile_file
from labsim.foundation.diagnostics import LabsimError
from labsim.foundation.limits import Budgets
from labsim.foundation.memory import memory_cap, out_of_memory
from labsim.runtime.run import compile_behaviour

HEAD = ("labsim: 1\nworld: road_loop\nstop: time >= 0.1\nrobots:\n  r:\n    model: pioneer_p3dx\n    count: COUNT\n"
        "    at: spawn\n    camera: {resolution: [SIDE, SIDE]}\n")
CHAIN = ("let:\n  g: gray(camera)\n  t: threshold(g, 20)\n  c: centroid(t)\n  k: invert(camera)\n"
         "rules:\n  - if mean(k) > 300 then wheels(0, 0)\n  - else wheels(c.x, c.y)\n")


def behaviour(tmp_path: Path, side: int = 100, count: int = 1, body: str = CHAIN) -> Path:
    path = tmp_path / "b.yaml"
    path.write_text(HEAD.replace("COUNT", str(count)).replace("SIDE", str(side)) + body, encoding="utf-8")
    return path


def test_an_image_only_signals_read_is_freed_after_its_last_reader(tmp_path: Path) -> None:
    program = compile_file(behaviour(tmp_path))
    slot = program.slot_of
    source = program.code.source
    g, t, k = slot["g"], slot["t"], slot["k"]
    assert f"s[{k}] = None" in source  # k, which a rule reads, is let go as the next tick starts
    assert f"s[{g}] = v{g} = None" in source and f"s[{t}] = v{t} = None" in source
    assert f"s[{k}] = v{k} = None" not in source  # never within the tick
    # g goes right after t, its last reader, and t right after c
    lines = [ln.strip() for ln in source.splitlines()]
    assert lines.index(f"s[{g}] = v{g} = None") == lines.index(f"s[{t}] = v{t} = _threshold(v{g}, 20.0)") + 2


def test_a_file_without_image_signals_has_the_code_it_had(tmp_path: Path) -> None:
    program = compile_file(behaviour(tmp_path, body="rules:\n  - always wheels(1, 1)\n"))
    assert not program.code.drops and "_drop" not in program.code.source


def test_the_estimate_counts_kept_images_per_robot(tmp_path: Path) -> None:
    # 5 robots of 800 x 800: each robot's frame (1.92 MB) and kept k (1.92 MB), and what one signal makes
    path = behaviour(tmp_path, side=800, count=5)
    # 9.6 MB of frames, 4 robots' k (7.68 MB) and the fifth robot's k as it is made: 19.2 MB
    with pytest.raises(LabsimError, match=r"b\.yaml:14:6: error: with signal 'k'.*memory budget of 19 MB.*"
                                          r"about 20 MB"):
        compile_file(path, budgets=Budgets(memory_mb=19))
    compile_file(path, budgets=Budgets(memory_mb=20))


def test_a_run_keeps_its_images_only_for_a_live_view(tmp_path: Path) -> None:
    behaviour_ = compile_behaviour(behaviour(tmp_path))
    slots_of = {}
    for watch in (False, True):
        run = behaviour_.bind(load_backend("pymunk"), watch=watch)
        try:
            run.run(max_ticks=2)
            slots_of[watch] = run.robots[0].program.slots
        finally:
            run.close()
    g = behaviour_.program.slot_of["g"]
    assert slots_of[False][g] is None and slots_of[True][g] is not None


def test_the_cap_holds_for_the_run_and_is_put_back() -> None:
    before = resource.getrlimit(resource.RLIMIT_AS)
    with memory_cap(100) as capped:
        assert capped
        with pytest.raises(MemoryError):
            bytearray(4 * 1024**3)
    assert resource.getrlimit(resource.RLIMIT_AS) == before
    with memory_cap(0) as capped:
        assert not capped


@pytest.mark.parametrize(("error", "is_oom"), [
    (MemoryError(), True),
    (type("error", (Exception,), {})("OpenCV(4.9.0) alloc.cpp:73: error: (-4:Insufficient memory) Failed to "
                                     "allocate 12000000 bytes"), True),
    (type("error", (Exception,), {})("(-215:Assertion failed) !_src.empty()"), False),
    (ValueError("Insufficient memory"), False),
])
def test_out_of_memory_is_memoryerror_or_opencvs_allocation_error(error: BaseException, is_oom: bool) -> None:
    assert out_of_memory(error) is is_oom


def test_an_image_a_group_reads_lives_until_the_group_is_made(tmp_path: Path) -> None:
    body = ("let:\n  a: invert(camera)\n  b: gray(a)\n  m: [mean(a), mean(b)]\n  n: m[1]\n"
            "rules:\n  - if max(m) > 300 then wheels(0, 0)\n  - else wheels(n, 1)\n")
    path = behaviour(tmp_path, side=64, body=body)
    path.write_text(path.read_text(encoding="utf-8").replace("labsim: 1\n", "labsim: 1.2\n"), encoding="utf-8")
    behaviour_ = compile_behaviour(path)
    lines = [ln.strip() for ln in behaviour_.program.code.source.splitlines()]
    a = behaviour_.program.slot_of["a"]
    freed = next(i for i, ln in enumerate(lines) if ln.startswith(f"s[{a}] = v{a} = ") and ln.endswith("None"))
    assert freed > next(i for i, ln in enumerate(lines) if "= _g1(v" in ln)  # after the group reads it
    run = behaviour_.bind(load_backend("pymunk"))
    try:
        result = run.run()
        assert result.ticks == 2 and not result.faults  # to its stop time, mean(a) of an image every tick
    finally:
        run.close()
