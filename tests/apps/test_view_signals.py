"""SIGTERM, SIGHUP and Ctrl-C end ``labsim view`` with its trace's footer, wherever they land.

A signal whose handler raises inside one of chipmunk's callbacks (the wheel drive the pymunk
backend installs as a velocity function) was lost: cffi reports the exception as ignored, and
the view ran on. The view's handlers only set a flag the tick loop reads
(``labsim.runtime.interrupts.StopSignals``). Here the signal is sent from inside that very
callback, at a different call in each trial, so every trial tests the case that was lost.
"""
from __future__ import annotations

import asyncio
import json
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from helpers import ROOT

from labsim.runtime.trace import read_trace

aiohttp = pytest.importorskip("aiohttp")
# a robot driven into a wall: the wheel drive's velocity callback runs on every step of a contact
# (a free body's velocity is set after the step), so the run must meet a wall, and soon
PUSHER = """labsim: 1.2
name: Into the wall
world: walls_lab4
stop: time >= 60
robots:
  pioneer: {model: pioneer_p3dx, at: [6.5, -4, 0]}
rules:
  - always move(4)
"""

# labsim view, with the wheel drive's C callback sending the signal to its own process on its
# CALL-th call, and entering a Python function there: the handler runs on that entry, inside
# the callback (without it, it would run only once the step returned to Python)
DRIVER = """
import os, signal, sys
import labsim.backends.pymunk.chipmunk as chipmunk
real, calls = chipmunk.set_angular_velocity, [0]
def entered():
    pass
def pinned(body, w):
    calls[0] += 1
    if calls[0] == {call}:
        import inspect
        caller = inspect.currentframe().f_back  # the drive's own function, called by chipmunk
        assert caller.f_code.co_name == "velocity", caller
        sys.stderr.write("signal sent from the velocity callback\\n")
        os.kill(os.getpid(), signal.{signal})
        entered()  # a Python function's entry runs the pending handler: here, inside the callback
    real(body, w)
def callback_only(init):  # the drives' callbacks get it; fleet.act's own calls keep the real one
    def wrapped(self, *args):
        chipmunk.set_angular_velocity = pinned
        try:
            init(self, *args)
        finally:
            chipmunk.set_angular_velocity = real
    return wrapped
chipmunk.WheelDrives.__init__ = callback_only(chipmunk.WheelDrives.__init__)
from labsim.runtime.cli.main import main
sys.exit(main(["view", {wall!r}, "--port", "0", "--no-browser", "--trace", {trace!r}]))
"""


async def _play(url: str) -> None:
    base, token = url.split("?token=")
    async with aiohttp.ClientSession() as http:
        ws = await http.ws_connect(f"{base}ws?token={token}")
        await ws.send_str(json.dumps({"type": "speed", "value": "max"}))
        await ws.send_str(json.dumps({"type": "play"}))
        try:
            while True:  # read (and acknowledge nothing) until the server goes, or the run ends
                msg = await ws.receive(timeout=30)
                if msg.type != aiohttp.WSMsgType.TEXT or json.loads(msg.data).get("finished"):
                    break
        finally:
            await ws.close()


def _trial(tmp_path: Path, call: int, name: str = "SIGTERM") -> tuple[int, str, Path]:
    trace = tmp_path / f"live-{name}-{call}.csv"
    pusher = tmp_path / "pusher.yaml"
    pusher.write_text(PUSHER, encoding="utf-8")
    code = DRIVER.format(call=call, signal=name, wall=str(pusher), trace=str(trace))
    p = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         cwd=ROOT)
    assert p.stdout is not None
    line = p.stdout.readline()
    assert " at http" in line, line
    try:
        asyncio.run(_play(line.split(" at ")[1].split()[0]))
        _, err = p.communicate(timeout=30)  # lost, the run would end and the view idle on: no exit at all
    except subprocess.TimeoutExpired:
        p.kill()
        _, err = p.communicate()
        raise AssertionError(f"trial {call}: {name} from the velocity callback was lost: {err[-400:]}") from None
    finally:
        if p.poll() is None:
            p.kill()
            p.communicate()
    return p.returncode, err, trace


@pytest.mark.slow
def test_sigterm_in_the_velocity_callback_ends_every_trial_with_a_footer(tmp_path: Path) -> None:
    for call in range(1, 21):
        code, err, trace = _trial(tmp_path, call * 7)
        assert "signal sent from the velocity callback" in err, err
        assert code == 143, err
        assert err.endswith("labsim view: stopped (SIGTERM)\n"), err
        assert "Traceback" not in err and "Exception ignored" not in err, err
        footer = read_trace(trace).footer
        assert footer is not None and footer["interrupted"] is True and footer["ticks"] > 0, (call, footer)


@pytest.mark.slow
@pytest.mark.parametrize("name, code", [("SIGHUP", 129), ("SIGINT", 130)])
def test_sighup_and_ctrl_c_in_the_callback_end_it_too(tmp_path: Path, name: str, code: int) -> None:
    returned, err, trace = _trial(tmp_path, 5, name)
    assert returned == code, err
    assert "Traceback" not in err and "Exception ignored" not in err, err
    footer = read_trace(trace).footer
    assert footer is not None and footer["interrupted"] is True


def test_a_second_signal_raises_and_the_handlers_are_put_back() -> None:
    from labsim.runtime.interrupts import StopSignals

    before = signal.getsignal(signal.SIGTERM)
    with StopSignals() as stop:
        signal.raise_signal(signal.SIGTERM)  # only a flag: nothing raised here
        assert stop.signum == signal.SIGTERM
        with pytest.raises(KeyboardInterrupt):
            signal.raise_signal(signal.SIGINT)
        assert stop.signum == signal.SIGTERM  # the first one caught
    assert signal.getsignal(signal.SIGTERM) is before
