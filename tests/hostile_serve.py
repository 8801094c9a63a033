"""Hostile requests for ``labsim serve``, as a table: what a broken or malicious client sends,
and what it gets back. tests/hostile/test_hostile_serve.py sends each to a ``labsim serve`` process and
then checks that a well-behaved client is still answered and that the server's memory stayed
under a bound.

A case's ``messages()`` builds the requests when the case runs (some are tens of megabytes), each
a list of ZeroMQ frames; ``expect`` says what each reply must be:

* ``Err("text")``: a reply ``{"err": ...}`` containing the text (CoppeliaSim's reply shape);
* ``RET``: a normal ``{"ret": [...]}`` reply;
* ``ANSWERED``: a reply of either kind (the case is about the server staying up);
* ``CLEAN``: a reply of any kind (``ret``, ``err``, ``_*wait*_``) that is not an internal error:
  a handler met arguments it did not expect and said so, rather than failing;
* ``VERSION``: the protocol-1 reply CoppeliaSim gives an old client;
* ``DROPPED``: no reply is owed (ZeroMQ drops an oversized message with its connection); if
  one comes, it must not be a normal one.

``vanish``: the client sends and closes its socket without waiting for the reply.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import cbor2

from labsim.runtime.serve.sim_api import FUNCTIONS, UNSUPPORTED
from labsim.runtime.serve.sim_objects import OBJECT_CALLS
from labsim.runtime.serve.sim_session import SESSION_CALLS
from labsim.runtime.serve.sim_signals import SIGNAL_CALLS

Frames = list[bytes]

E_CBOR = "not a CBOR message"
E_SHAPE = "a CBOR map with a 'func' text"
E_ARGS = "argument type is not correct"
E_PATH = "object does not exist, or alias/path is ill formatted"
E_HANDLE = "object does not exist"
E_VALUES = "at most 1000000 values"
E_DEPTH = "nest at most 16"
E_TEXT = "a text in a request may be at most"
E_TAGS = "CBOR tags are not part of"
E_FRAMES = "one ZeroMQ frame"


@dataclass(frozen=True)
class Err:
    text: str


@dataclass(frozen=True)
class Expect:
    name: str


RET = Expect("ret")
ANSWERED = Expect("answered")
CLEAN = Expect("clean")
VERSION = Expect("version")
DROPPED = Expect("dropped")


@dataclass(frozen=True)
class Case:
    name: str
    messages: Callable[[], list[Frames]]
    expect: Err | Expect
    vanish: bool = False


def req(func: object, *args: object, uuid: object = "hostile-client", **extra: object) -> bytes:
    """A request as CoppeliaSim's Python client builds it, with ``extra`` keys over it."""
    body: dict[object, object] = {"func": func, "args": list(args), "argsL": len(args), "uuid": uuid}
    body.update(extra)
    return cbor2.dumps(body)


def one(raw: bytes) -> Callable[[], list[Frames]]:
    return lambda: [[raw]]


def _head(major: int, n: int) -> bytes:
    """A CBOR head with a 4-byte argument: major type ``major``, length ``n``."""
    return bytes([major << 5 | 26]) + n.to_bytes(4, "big")


def _request_with_raw_arg(arg: bytes) -> bytes:
    """sim.getObject whose single argument is the CBOR bytes ``arg``, spliced in undecoded."""
    prefix = cbor2.dumps({"func": "sim.getObject", "uuid": "hostile-client", "argsL": 1})
    # the map has 3 entries (0xa3); make it 4, and add "args": [arg]
    return bytes([0xA4]) + prefix[1:] + cbor2.dumps("args") + b"\x81" + arg


def _fresh_clients(n: int) -> list[Frames]:
    return [[req("sim.getSimulationTime", uuid=f"fresh-{k:06d}", ver=2, lang="python", timeout=600)]
            for k in range(n)]


MIB = 1024 * 1024

CASES: list[Case] = [
    # --- not the protocol at all --------------------------------------------------------------
    Case("garbage bytes", one(b"\xff\xfe\x00garbage\x01"), Err(E_CBOR)),
    Case("an empty message", one(b""), Err(E_CBOR)),
    Case("text, not CBOR", one(b"GET / HTTP/1.1\r\nHost: x\r\n\r\n"), Err(E_CBOR)),
    Case("truncated CBOR", one(req("sim.getObject", "/PioneerP3DX")[:-3]), Err(E_CBOR)),
    Case("bytes after the map", one(req("sim.getSimulationTime") + b"\x00"), Err("bytes follow its first value")),
    Case("invalid UTF-8 in a text", one(_request_with_raw_arg(b"\x62\xff\xfe")), Err(E_CBOR)),
    Case("a reserved header byte", one(b"\x1c"), Err(E_CBOR)),
    Case("a stray break", one(b"\xff"), Err(E_CBOR)),
    Case("an indefinite array never closed", one(b"\x9f\x01\x02\x03"), Err(E_CBOR)),
    Case("an array claiming more items than bytes", one(_head(4, 500_000) + b"\x00" * 10), Err(E_CBOR)),
    Case("a text claiming more bytes than the message", one(_head(3, 4_000) + b"abc"), Err(E_CBOR)),
    # --- CBOR, but not a request ---------------------------------------------------------------
    Case("a list, not a map", one(cbor2.dumps(["sim.getObject", "/a"])), Err(E_SHAPE)),
    Case("a number", one(cbor2.dumps(42)), Err(E_SHAPE)),
    Case("func is a number", one(req(17)), Err(E_SHAPE)),
    Case("func missing", one(cbor2.dumps({"args": [], "uuid": "x"})), Err(E_SHAPE)),
    Case("no uuid: a protocol-1 client", one(cbor2.dumps({"func": "sim.getObject", "args": ["/a"]})), VERSION),
    Case("uuid is a list", one(req("sim.getSimulationTime", uuid=[1, 2, 3])), Err("'uuid' is a text")),
    Case("uuid of 10,000 characters", one(req("sim.getSimulationTime", uuid="u" * 10_000)), Err("'uuid' is a text")),
    Case("args is a map", one(cbor2.dumps({"func": "sim.getObject", "args": {"a": 1}, "uuid": "x"})), Err(E_ARGS)),
    Case("args is null", one(cbor2.dumps({"func": "sim.getSimulationTime", "args": None, "uuid": "x"})), RET),
    Case("an unknown function", one(req("os.system", "rm -rf /")), Err("No such function: os.system")),
    Case("a dunder function name", one(req("sim.__class__")), Err("No such function")),
    Case("a function name of 60,000 characters", one(req("sim." + "x" * 60_000)), Err("No such function")),
    Case("argsL negative and huge", one(req("sim.getSimulationTime", argsL=-(2**63))), RET),
    Case("timeout NaN on first contact", one(req("sim.getSimulationTime", uuid="nan-timeout", ver=2,
                                                 timeout=float("nan"))), RET),
    Case("timeout infinite on first contact", one(req("sim.getSimulationTime", uuid="inf-timeout", ver=2,
                                                      timeout=float("inf"))), RET),
    # --- wrong arguments to real functions -----------------------------------------------------
    Case("getObject of a number", one(req("sim.getObject", 5)), Err(E_ARGS)),
    Case("getObject with no argument", one(req("sim.getObject")), Err("requires more arguments")),
    Case("getObject with options a text", one(req("sim.getObject", "/PioneerP3DX", "x")), Err(E_ARGS)),
    Case("getObject index 2**64 - 1", one(req("sim.getObject", "/PioneerP3DX", {"index": 2**64 - 1})), Err(E_PATH)),
    Case("getObject proxy -2**64", one(req("sim.getObject", "./leftMotor", {"proxy": -(2**64)})), Err(E_HANDLE)),
    Case("setJointTargetVelocity NaN", one(req("sim.setJointTargetVelocity", 2, float("nan"))), Err(E_ARGS)),
    Case("setJointTargetVelocity infinite", one(req("sim.setJointTargetVelocity", 2, float("inf"))), Err(E_ARGS)),
    Case("setJointTargetVelocity of texts", one(req("sim.setJointTargetVelocity", "a", "b")), Err(E_ARGS)),
    Case("a handle of 2**64 - 1", one(req("sim.readProximitySensor", 2**64 - 1)), Err(E_HANDLE)),
    Case("a half-precision NaN", one(_request_with_raw_arg(b"\xf9\x7e\x00")), Err(E_ARGS)),
    Case("undefined as an argument", one(_request_with_raw_arg(b"\xf7")), Err(E_ARGS)),
    Case("setObjectPosition of 1e308s", one(req("sim.setObjectPosition", 1, [1e308] * 3)), ANSWERED),
    Case("setObjectOrientation to an infinite yaw", one(req("sim.setObjectOrientation", 1, [0, 0, float("inf")], -1)),
         Err(E_ARGS)),
    Case("buildMatrix of infinities", one(req("sim.buildMatrix", [float("inf"), 0, 0], [0, 0, float("inf")])),
         Err(E_ARGS)),
    Case("setObjectMatrix of a NaN", one(req("sim.setObjectMatrix", 1, [float("nan")] * 12, -1)), Err(E_ARGS)),
    Case("_*executed*_ out of turn", one(req("_*executed*_")), RET),
    Case("zmqRemoteApi.require of os", one(req("zmqRemoteApi.require", "os")), Err("not found")),
    Case("zmqRemoteApi.info of a list", one(req("zmqRemoteApi.info", [1] * 1000)), Err("no object")),
    # --- object paths (issue: one path wedged the server) --------------------------------------
    Case("sixteen stars and a Z", one(req("sim.getObject", "/" + "*" * 16 + "Z")), Err(E_PATH)),
    Case("a thousand stars and a Z", one(req("sim.getObject", "/" + "*" * 1000 + "Z")), Err(E_PATH)),
    Case("stars between letters", one(req("sim.getObject", "/" + "*P" * 5000 + "Z")), Err(E_PATH)),
    Case("question marks", one(req("sim.getObject", "/" + "?" * 60_000)), Err(E_PATH)),
    Case("30,000 segments", one(req("sim.getObject", "/a" * 30_000)), Err(E_PATH)),
    Case("an index of 30 digits", one(req("sim.getObject", "/PioneerP3DX[" + "9" * 30 + "]")), Err(E_PATH)),
    Case("an index of 5,000 digits", one(req("sim.getObject", "/PioneerP3DX{" + "9" * 5_000 + "}")), Err(E_PATH)),
    Case("unicode digits in an index", one(req("sim.getObject", "/PioneerP3DX[\u0663]")), Err(E_PATH)),
    Case("control characters in a path", one(req("sim.getObject", "/Pioneer\x00P3DX\n")), Err(E_PATH)),
    Case("a relative path with no proxy: from the top", one(req("sim.getObject", "./" + "*" * 40 + "Z")), Err(E_PATH)),
    Case("a thousand star segments", one(req("sim.getObject", "/" + "*/" * 1000 + "Z")), Err(E_PATH)),
    Case("star segments from the model", one(req("sim.getObject", ":/" + "*?/" * 500 + "Z")), Err(E_PATH)),
    Case("a format string as a path", one(req("sim.getObject", "/P{i.__class__.__mro__[1]}")), Err(E_PATH)),
    # --- size, depth and count (issue: memory to gigabytes, minutes of work) -------------------
    Case("a 50 MB text", one(req("sim.getObject", "x" * (50 * MIB))), Err(E_TEXT)),
    Case("a 50 MB byte string", one(req("sim.getObject", b"\0" * (50 * MIB))), Err(E_ARGS)),
    Case("an array of 52 million zeros",
         one(_request_with_raw_arg(_head(4, 52_000_000) + b"\0" * 52_000_000)), Err(E_VALUES)),
    Case("10 million empty maps",
         one(_request_with_raw_arg(_head(4, 10_000_000) + b"\xa0" * 10_000_000)), Err(E_VALUES)),
    Case("an indefinite array of 2 million zeros",
         one(_request_with_raw_arg(b"\x9f" + b"\0" * 2_000_000 + b"\xff")), Err(E_VALUES)),
    Case("arrays nested 100,000 deep", one(_request_with_raw_arg(b"\x81" * 100_000 + b"\0")), Err(E_DEPTH)),
    Case("maps nested 1,000 deep", one(_request_with_raw_arg(b"\xa1\x00" * 1_000 + b"\0")), Err(E_DEPTH)),
    Case("nested 12 deep: allowed", one(_request_with_raw_arg(b"\x81" * 12 + b"\0")), Err(E_ARGS)),
    Case("an indefinite text of 70,000 bytes in chunks",
         one(_request_with_raw_arg(b"\x7f" + b"\x79\x03\xe8" + b"a" * 1000 + b"\x79\x03\xe8" + b"a" * 1000
                                   + (b"\x79\x03\xe8" + b"a" * 1000) * 68 + b"\xff")), Err(E_TEXT)),
    Case("a bignum of 10,000 bytes", one(_request_with_raw_arg(b"\xc2" + b"\x59\x27\x10" + b"\xff" * 10_000)),
         Err(E_TAGS)),
    Case("a shared-value cycle", one(_request_with_raw_arg(b"\xd8\x1c\x81\xd8\x1d\x00")), Err(E_TAGS)),
    Case("a decimal fraction of exponent 2**63", one(_request_with_raw_arg(
        b"\xc4\x82\x1b" + (2**63 - 1).to_bytes(8, "big") + b"\x01")), Err(E_TAGS)),
    # --- what a client makes the server keep or decode (issue: 1.2 GB of signals, a 31 s unpack)
    Case("unpackFloatTable of 40 MB", one(req("sim.unpackFloatTable", b"\0" * (40 * MIB))),
         Err("an unpack returns at most 1048576 values; this one would return 10485760")),
    Case("unpackDoubleTable of 9 MB, counted", one(req("sim.unpackDoubleTable", b"\0" * (9 * MIB), 0, 2**62)),
         Err("an unpack returns at most 1048576 values; this one would return 1179648")),
    Case("unpack with a start past the end", one(req("sim.unpackFloatTable", b"\0" * 8, 2**62, 5)), RET),
    Case("a 17 MB string signal", one(req("sim.setStringSignal", "big", b"\0" * (17 * MIB))),
         Err("a signal holds at most 16 MiB; 'big' was given 17825792 bytes")),
    Case("an int32 signal of 2**40", one(req("sim.setInt32Signal", "n", 2**40)), Err("an int32 signal holds")),
    Case("a float signal of a text", one(req("sim.setFloatSignal", "f", "x")), Err(E_ARGS)),
    Case("an int32 signal of NaN", one(req("sim.setInt32Signal", "n", float("nan"))), Err(E_ARGS)),
    Case("a float handle of 1e300", one(req("sim.getObjectAlias", 1e300)), Err(E_ARGS)),
    Case("a 70 MB message, over the socket's limit", one(req("sim.getObject", b"\0" * (70 * MIB))), DROPPED),
    # --- frames (issue: a 2-frame request was never answered) ----------------------------------
    Case("two frames", lambda: [[req("sim.getSimulationTime"), req("sim.getSimulationTime")]], Err(E_FRAMES)),
    Case("three frames of garbage", lambda: [[b"a", b"", b"\xff" * 100]], Err(E_FRAMES)),
    Case("an empty frame then a request", lambda: [[b"", req("sim.getSimulationTime")]], Err(E_FRAMES)),
    # --- clients that misbehave over time ------------------------------------------------------
    Case("a client that vanishes before its reply", one(req("sim.getObject", "/" + "*" * 16 + "Z")), DROPPED,
         vanish=True),
    Case("2,000 fresh client ids", lambda: _fresh_clients(2_000), RET),
    Case("stepping, then vanishing", lambda: [[req("sim.setStepping", True, uuid="stepper", ver=2)],
                                              [req("sim.startSimulation", uuid="stepper")]], RET),
]

# Every function the stand-in lists, with arguments of every wrong kind: handles that do not
# exist, 2**64 - 1, NaN, 1e308, texts, nested lists, maps, too few and too many.
WRONG_ARGS: list[list[object]] = [
    [], ["\x00" * 100, -1, 1e308, [[]], {"k": None}], [1, {"a": 1}, [1e308] * 3, -(2**63)],
    [2**64 - 1, 2**64 - 1, 2**64 - 1], [1, 1, [float("nan")] * 3], [1, -1, "x"], [3, [1, 2], list(range(7))],
    [1, -1, [1e308] * 3], [1, [1e308] * 7, -1], [2, 1e308], [5, float("-inf")], [4, 2, [0, 0], [10**6, 10**6]],
    [7, 0, [-5, 3], [2**63, 1]], [None] * 8, [True, False, True],
]
# (less the two that replace the scene the cases share: tests/serve/test_serve_lifecycle.py sends them these)
SCENE_CHANGING = ("sim.loadScene", "sim.closeScene")
EVERY_FUNCTION = (*FUNCTIONS, *(f"sim.{name}" for name in UNSUPPORTED),
                  *(f for f in (*SESSION_CALLS, *OBJECT_CALLS, *SIGNAL_CALLS) if f not in SCENE_CHANGING),
                  "zmqRemoteApi.require", "zmqRemoteApi.info")
CASES += [Case(f"{func} with wrong arguments", (lambda func=func: [[req(func, *args)] for args in WRONG_ARGS]), CLEAN)
          for func in EVERY_FUNCTION]
