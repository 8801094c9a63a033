"""``labsim scene FILE``: build the scene a behaviour needs in a running CoppeliaSim.

Where it sits: a command of the command line (``cli``), next to ``labsim serve``. It compiles
the behaviour, works out the robots' start poses exactly as a run does (``run.Run`` opened on
a backend that only keeps what it is asked for), and hands the world and the robots to
``labsim.runtime.builder.scene``, which builds them through the ZMQ remote API.
Then ``labsim run FILE --backend coppeliasim`` runs the lab in that scene.
"""
from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from labsim.backends.coppeliasim import DEFAULT_PORT
from labsim.backends.protocol import BackendError, ContactStats, RobotRequest
from labsim.backends.scene.world import World
from labsim.foundation import options
from labsim.foundation.diagnostics import Diagnostic, LabsimError
from labsim.foundation.exits import EXIT_OK
from labsim.runtime.run import Run, compile_behaviour


def add_scene_arguments(scene: argparse.ArgumentParser) -> None:
    """``labsim scene``'s options; docs/coppeliasim.md."""
    scene.add_argument("file", help="the behaviour file (.yaml), or a lab's name (labsim labs)")
    scene.add_argument("--host", type=options.host, default="127.0.0.1",
                       help="CoppeliaSim's address (default: %(default)s)")
    scene.add_argument("--port", type=options.port, default=DEFAULT_PORT,
                       help="its ZMQ remote API port (default: %(default)s)")
    scene.add_argument("--timeout", type=options.timeout_s, default=5.0, metavar="SECONDS",
                       help="how long to wait for each answer (default: %(default)s)")
    scene.add_argument("--save", metavar="PATH.ttt", help="then save the scene to this file (CoppeliaSim writes it)")
    scene.add_argument("--quiet", "-q", action="store_true", help="print nothing but errors")


class _StartPoses:
    """A backend that only keeps the robots a run asks it to open: their start poses."""

    name = "scene"

    def __init__(self) -> None:
        self.robots: list[RobotRequest] = []

    def open(self, world: World, robots: Sequence[RobotRequest], dt_s: float, seed: int) -> None:
        self.robots = list(robots)

    def sense(self) -> list[list[object]]:
        raise BackendError("labsim scene runs nothing")

    def act(self, robot: int, left_rad_s: float, right_rad_s: float) -> None:
        raise BackendError("labsim scene runs nothing")

    def step(self) -> None:
        raise BackendError("labsim scene runs nothing")

    def command(self, robot: int, joint: str, mode: str, value: float) -> None:
        raise BackendError("labsim scene runs nothing")

    def pose(self, robot: int) -> tuple[float, float, float]:
        raise BackendError("labsim scene runs nothing")

    def contacts(self, robot: int) -> ContactStats:
        return ContactStats(0, 0.0)

    def close(self) -> None:
        pass


def run_scene(args: argparse.Namespace) -> int:
    """Build the behaviour's scene; 0 when built, 2 (through BackendError) when not."""
    from labsim.backends.coppeliasim.connection import Connection
    from labsim.runtime.builder.scene import build, unsupported

    if not 0 < args.port < 65536:
        raise LabsimError([Diagnostic("--port", "give a port from 1 to 65535")])
    if not args.timeout > 0:
        raise LabsimError([Diagnostic("--timeout", "give a positive number of seconds")])
    if args.save is not None and not args.save.endswith(".ttt"):
        raise LabsimError([Diagnostic("--save", "give a CoppeliaSim scene file name ending in .ttt")])
    if args.save is not None and args.host in ("127.0.0.1", "localhost", "::1"):
        # CoppeliaSim writes the file from its own working folder: give it the path the user means
        save = Path(args.save).expanduser().absolute()
        if not save.parent.is_dir():
            raise LabsimError([Diagnostic(args.save, f"cannot save the scene there: no folder {save.parent}")])
        args.save = str(save)
    program = compile_behaviour(args.file).program
    why = unsupported(program.world)
    if why:
        raise BackendError(f"labsim scene: {why}")
    poses = _StartPoses()
    Run(program, poses)
    robots = [r for r in poses.robots if r.model is not None]

    def log(line: str) -> None:
        if not args.quiet:
            print(line, flush=True)

    build(Connection(args.host, args.port, args.timeout), program.world, robots, program.dt_s, args.save, log)
    log(f"labsim scene: built {program.world.name} at {args.host}:{args.port}, dt {program.dt_s:g} s; "
        f"now: labsim run {args.file} --backend coppeliasim --port {args.port}")
    sys.stdout.flush()
    return EXIT_OK
