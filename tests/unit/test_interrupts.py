"""Ctrl-C that lands inside a chipmunk callback during a step still interrupts the run
(labsim.runtime.interrupts): cffi would otherwise print it as ignored and step on."""
from __future__ import annotations

import sys

import pymunk
import pytest
from pymunk._chipmunk_cffi import ffi, lib

from labsim.runtime.interrupts import CallbackInterrupts


def _space_whose_step_raises(exc: BaseException) -> tuple[pymunk.Space, object]:
    space = pymunk.Space()
    body = pymunk.Body(1, 1)
    space.add(body, pymunk.Circle(body, 0.1))

    def velocity(_body: object, _gravity: object, _damping: float, _dt: float) -> None:
        raise exc  # as a signal handler's exception would be, between the callback's bytecodes

    callback = ffi.callback("cpBodyVelocityFunc", velocity)
    lib.cpBodySetVelocityUpdateFunc(body._body, callback)
    return space, callback


class Terminated(KeyboardInterrupt):
    """As the CLI's SIGTERM."""


@pytest.mark.parametrize("interrupt", [KeyboardInterrupt, Terminated])
def test_an_interrupt_inside_a_callback_is_raised_at_the_check(interrupt: type, monkeypatch) -> None:
    seen: list[object] = []
    monkeypatch.setattr(sys, "unraisablehook", seen.append)
    space, _keep = _space_whose_step_raises(interrupt())
    with CallbackInterrupts() as caught:
        space.step(0.05)  # the callback's exception cannot unwind through chipmunk
        with pytest.raises(interrupt):
            caught.check()
        caught.check()  # raised once
    assert not seen  # nothing printed as ignored


def test_an_interrupt_in_the_last_block_is_raised_on_leaving() -> None:
    space, _keep = _space_whose_step_raises(KeyboardInterrupt())
    with pytest.raises(KeyboardInterrupt), CallbackInterrupts():
        space.step(0.05)


def test_without_it_the_interrupt_is_lost(monkeypatch) -> None:
    seen: list[object] = []
    monkeypatch.setattr(sys, "unraisablehook", seen.append)
    space, _keep = _space_whose_step_raises(KeyboardInterrupt())
    space.step(0.05)  # nothing comes out: why the tick loop keeps what callbacks swallow
    assert [type(u.exc_value) for u in seen] == [KeyboardInterrupt]  # type: ignore[attr-defined]


def test_other_errors_in_a_callback_are_reported_as_before(monkeypatch) -> None:
    seen: list[object] = []
    monkeypatch.setattr(sys, "unraisablehook", seen.append)
    space, _keep = _space_whose_step_raises(ValueError("boom"))
    with CallbackInterrupts() as caught:
        space.step(0.05)
        caught.check()
    assert [type(u.exc_value) for u in seen] == [ValueError]  # type: ignore[attr-defined]
    assert sys.unraisablehook == seen.append  # restored
