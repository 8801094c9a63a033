"""The ``labsim`` command line's options: one small function per command declares them.

``build_parser(argv)`` gives every command its name and help (what ``labsim --help`` lists) but
declares the options of the one command ``argv`` names only, so that ``labsim run`` never
imports a sweep, the pictures, the live view, the stand-in server or the scene builder: the
commands whose options live with their application (``sweep``, ``plot``, ``scene``) import it
only when they are the command. Shell completion asks for every command's options
(``every=True``). ``labsim.runtime.cli.main`` parses with it and runs the command.
"""
from __future__ import annotations

import argparse
import importlib.machinery
import importlib.util
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import NoReturn

from labsim.backends import DEFAULT, REGISTRY
from labsim.backends.coppeliasim import DEFAULT_PORT
from labsim.foundation import options
from labsim.foundation.exits import EXIT_USAGE
from labsim.foundation.limits import Budgets
from labsim.foundation.version import version

BEHAVIOUR_HELP = "the behaviour file (.yaml), or a lab's name (labsim labs)"


class _Parser(argparse.ArgumentParser):
    """argparse's parser, a mistake in the options reported as ``labsim: error: ...``, exit 2."""

    def error(self, message: str) -> NoReturn:
        self.print_usage(sys.stderr)
        sys.stderr.write(f"labsim: error: {message}\n")
        raise SystemExit(EXIT_USAGE)


@dataclass(frozen=True)
class Command:
    """A command: its name, its line in ``labsim --help``, and the function that declares its options."""

    name: str
    help: str
    declare: Callable[[argparse.ArgumentParser], None]


def build_parser(argv: Sequence[str] | None = None, *, every: bool = False) -> argparse.ArgumentParser:
    """The parser for ``argv`` (default: this process's arguments); with every command's options
    when ``every``."""
    named = _command_named(sys.argv[1:] if argv is None else argv)
    p = _Parser(prog="labsim", description="Run robotics labs written as behaviour files.")
    p.add_argument("--version", action=_Version, help="show labsim's version and which ray caster runs, and exit")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)
    for command in COMMANDS:
        declared = sub.add_parser(command.name, help=command.help)
        if every or command.name == named:
            command.declare(declared)
    return p


def ray_caster() -> str:
    """Which caster the embedded simulator's ray sensors (sonars, IR, lidar) use: "C kernel"
    where ``pip install`` found a compiler and built ``backends/pymunk/_fan.c`` (and it runs
    with this pymunk), else "Python" (chipmunk's casts from Python, the lidar's fan with numpy);
    asked without importing numpy."""
    if importlib.util.find_spec("labsim.backends.pymunk._fan") is None:
        return "Python"
    from labsim.backends.pymunk import ray_cast

    return "C kernel" if ray_cast.KERNEL == "c" else "Python"


def view_hook() -> str:
    """Which records a live view's ticks: "C" where ``pip install`` built ``runtime/view/_tap.c``,
    else "Python" (``labsim.runtime.view.peaks.KERNEL``); the file looked for, not imported (the
    view's package imports numpy)."""
    runtime = importlib.util.find_spec("labsim.runtime")
    folders = runtime.submodule_search_locations if runtime is not None else None
    built = any((Path(folder) / "view" / f"_tap{suffix}").is_file()
                for folder in folders or () for suffix in importlib.machinery.EXTENSION_SUFFIXES)
    return "C" if built else "Python"


class _Version(argparse.Action):
    """``--version``: labsim's version, which ray caster runs (``ray_caster``) and which records a
    live view's ticks (``view_hook``)."""

    def __init__(self, option_strings: Sequence[str], dest: str = argparse.SUPPRESS,
                 default: str = argparse.SUPPRESS, help: str | None = None) -> None:
        super().__init__(option_strings, dest=dest, default=default, nargs=0, help=help)

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace, values: object,
                 option_string: str | None = None) -> None:
        print(f"labsim {version()} (ray caster: {ray_caster()}; live view's tick hook: {view_hook()})")
        parser.exit()


def note_without_kernel() -> None:
    """Once an install (this labsim, from this folder), on its first run: a note that the ray
    sensors cast without the C kernel, when the install built none. Remembered by an empty file
    in the cache folder; where there is none, nothing is said rather than the note every run."""
    if ray_caster() == "C kernel":
        return
    import hashlib

    from labsim.foundation.cache import cache_dir, write_atomically
    from labsim.foundation.version import version

    folder = cache_dir()
    if folder is None:
        return
    where = hashlib.sha256(f"{version()} {Path(__file__).resolve().parents[2]}".encode()).hexdigest()
    marker = folder / f"noted-no-ray-kernel-{where[:16]}"
    if marker.exists() or not write_atomically(marker, b""):
        return
    print("note: the ray sensors cast without labsim's C kernel (no C compiler at install): the same "
          "readings, slower; `labsim --version` says which caster runs", file=sys.stderr)


def _command_named(argv: Sequence[str]) -> str | None:
    """The command the arguments name: the first that is no option (labsim's own options,
    --help and --version, take no value)."""
    return next((a for a in argv if not a.startswith("-")), None)


# -- the commands on the tick loop ---------------------------------------------------------------

def _run(p: argparse.ArgumentParser) -> None:
    p.add_argument("file", help=BEHAVIOUR_HELP)
    _set_seed(p)
    p.add_argument("--trace", metavar="PATH", help="write the trace (CSV) to PATH; to PATH.mcap, as an MCAP file "
                                                   "(labsim export, docs/mcap.md)")
    p.add_argument("--replay", metavar="TRACE", help="move the sliders as a recorded trace did "
                                                     "(instead of the file's timeline)")
    p.add_argument("--backend", default=DEFAULT, choices=sorted(REGISTRY), help="simulator (default: %(default)s)")
    _remote(p)
    p.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                   help="show a progress bar (default: when stderr is a terminal)")
    p.add_argument("--quiet", "-q", action="store_true", help="print no summary")
    p.add_argument("--json", nargs="?", const="-", default=None, metavar="PATH|-",
                   help="write the summary as JSON to PATH; with - or no PATH to standard output, instead of "
                        "the text summary (docs/summary-json.md)")
    p.add_argument("--break", dest="break_when", metavar="COND",
                   help="stop at the first tick the condition COND holds (as a view's breakpoint, e.g. "
                        "'min(sonar5, sonar2) < 0.5') and print that tick, its state and rule and the values "
                        "COND reads, instead of the summary")
    _strict(p)
    _allow_path(p)
    _budget(p)


def _check(p: argparse.ArgumentParser) -> None:
    p.add_argument("files", nargs="+")
    p.add_argument("--show-code", action="store_true",
                   help="print the Python each file compiles to, each rule, signal and metric "
                        "under a comment with its line in the file")
    p.add_argument("--json", action="store_true",
                   help="print every diagnostic as JSON (file, line, column, severity, message, hint) on standard "
                        "output instead of the text; the exit code is the same")
    _strict(p)
    _allow_path(p)
    _budget(p)


def _test(p: argparse.ArgumentParser) -> None:
    p.add_argument("paths", nargs="*", default=None,
                   help="behaviour files, folders or lab names (default: ./behaviours if there is "
                        "one, else the labs labsim ships)")
    p.add_argument("--update-goldens", action="store_true", help="record the golden traces anew")
    p.add_argument("--backend", default=DEFAULT, choices=sorted(REGISTRY),
                   help="simulator to re-run them on (default: %(default)s)")
    _remote(p)
    _strict(p)
    _allow_path(p)


def _labs(p: argparse.ArgumentParser) -> None:
    pass  # no options


def _new(p: argparse.ArgumentParser) -> None:
    p.add_argument("lab", help="the lab's name (labsim labs lists them)")
    p.add_argument("folder", nargs="?", default=".", help="where to put it (default: this folder)")


def _worlds(p: argparse.ArgumentParser) -> None:
    pass  # no options


def _schema(p: argparse.ArgumentParser) -> None:
    p.add_argument("kind", choices=("behaviour", "world", "assignment"))


# -- the commands of the applications ------------------------------------------------------------

def _export(p: argparse.ArgumentParser) -> None:
    p.description = ("Write a trace as an MCAP file that Foxglove and Rerun open: the robots' poses, every "
                     "column as a channel to plot, states, events and the world's walls (docs/mcap.md).")
    p.add_argument("trace", help="a trace written by labsim run --trace (or a golden)")
    p.add_argument("-o", "--output", required=True, metavar="FILE.mcap", help="the MCAP file to write")
    _allow_path(p)


def _lsp(p: argparse.ArgumentParser) -> None:
    p.add_argument("--stdio", action="store_true",
                   help="talk over standard input and output (the default and only way; editors pass it)")
    _allow_path(p)


def _sweep(p: argparse.ArgumentParser) -> None:
    from labsim.runtime.sweep.driver import add_sweep_arguments

    add_sweep_arguments(p)
    _strict(p)
    _allow_path(p)
    _budget(p)


def _grade(p: argparse.ArgumentParser) -> None:
    from labsim.runtime.grade.driver import add_grade_arguments

    add_grade_arguments(p)
    _allow_path(p)


def _plot(p: argparse.ArgumentParser) -> None:
    from labsim.runtime.pictures.driver import add_plot_arguments

    add_plot_arguments(p)
    _allow_path(p)


def _view(p: argparse.ArgumentParser) -> None:
    p.add_argument("file", help="a behaviour file (.yaml), or a trace (.csv) to replay")
    _set_seed(p)
    p.add_argument("--backend", default=DEFAULT, choices=sorted(REGISTRY), help="simulator (default: %(default)s)")
    p.add_argument("--host", type=options.host, default="127.0.0.1",
                   help="address to serve the page on (default: %(default)s, this computer only)")
    p.add_argument("--port", type=options.port, default=8765, help="port to serve the page on; 0 picks a free one "
                                                                   "(default: %(default)s)")
    p.add_argument("--trace", metavar="PATH", help="record the live run, slider moves included, to PATH")
    p.add_argument("--no-browser", action="store_true", help="print the URL only; do not open a browser")
    p.add_argument("--break", dest="breaks", action="append", default=[], metavar="WHEN",
                   help="pause the live run when WHEN happens: a condition ('sonar5 < 0.3'), 'state', "
                        "'state:NAME', 'rule:ID' or 'time:SECONDS' (repeatable)")
    p.add_argument("--read-only", action="store_true", help="no editing or saving the file in the page")
    p.add_argument("--no-token", action="store_true",
                   help="serve the page without its session token (anyone who can reach the port can watch and "
                        "steer the run; Save is then off)")
    p.add_argument("--sim-host", type=options.host, default=None,
                   help="CoppeliaSim's address, with --backend coppeliasim (default: 127.0.0.1)")
    p.add_argument("--sim-port", type=options.port, default=None,
                   help=f"CoppeliaSim's ZMQ remote API port, with --backend coppeliasim (default: {DEFAULT_PORT})")
    p.add_argument("--sim-timeout", type=options.timeout_s, default=None, metavar="SECONDS",
                   help="give up when CoppeliaSim does not answer within this (default: 5)")
    _strict(p)
    _allow_path(p)
    _budget(p)


def _serve(p: argparse.ArgumentParser) -> None:
    p.add_argument("world", nargs="?", default=None,
                   help="a built-in world (labsim worlds) or a world file (default: walls_lab4, "
                        "or the world of --for)")
    p.add_argument("--port", type=options.port, default=DEFAULT_PORT,
                   help="port to listen on; 0 picks a free one (default: %(default)s)")
    p.add_argument("--host", type=options.host, default="127.0.0.1",
                   help="address to listen on (default: %(default)s, this computer only)")
    p.add_argument("--robots", type=options.robots, default=None, metavar="N",
                   help="Pioneer P3DX robots, at the world's spawn poses (default: 1; 0 for a "
                        "world with a mechanism)")
    p.add_argument("--dt", type=options.time_step_s, default=None, metavar="SECONDS",
                   help="simulation time step (default: 0.05, CoppeliaSim's, or the dt of --for)")
    p.add_argument("--for", dest="behaviour", metavar="FILE",
                   help="serve the scene a behaviour file needs: its world, dt and robots, with "
                        "their cameras")
    p.add_argument("--quiet", "-q", action="store_true", help="do not log clients and simulations")
    p.add_argument("--empty", action="store_true",
                   help="start from an empty scene, to be built through the remote API (labsim scene)")
    p.add_argument("--per-object", action="store_true",
                   help="serve the scene without labsim's fleet script, as a scene built by hand: "
                        "clients read it object by object (more round trips a tick)")
    _allow_path(p)


def _scene(p: argparse.ArgumentParser) -> None:
    from labsim.runtime.builder.command import add_scene_arguments

    add_scene_arguments(p)
    _allow_path(p)


# -- options several commands take ---------------------------------------------------------------

def _set_seed(p: argparse.ArgumentParser) -> None:
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                   help="override a parameter from the file's 'params:' (repeatable)")
    p.add_argument("--seed", type=int, help="override the file's seed")


def _remote(p: argparse.ArgumentParser) -> None:
    p.add_argument("--host", type=options.host, default=None, help="CoppeliaSim's address, with --backend "
                                                                   "coppeliasim (default: 127.0.0.1)")
    p.add_argument("--port", type=options.port, default=None,
                   help=f"CoppeliaSim's ZMQ remote API port, with --backend coppeliasim (default: {DEFAULT_PORT})")
    p.add_argument("--timeout", type=options.timeout_s, default=None, metavar="SECONDS",
                   help="give up when CoppeliaSim does not answer within this, with --backend coppeliasim "
                        "(default: 5)")


def _strict(p: argparse.ArgumentParser) -> None:
    p.add_argument("--strict", action="store_true",
                   help="treat the behaviour files' warnings as errors (exit code 2)")


def _allow_path(p: argparse.ArgumentParser) -> None:
    p.add_argument("--allow-path", action="append", default=[], metavar="DIR",
                   help="let behaviour files and traces read files in DIR too, not only in "
                        "their own folder (repeatable; docs/security.md)")


def _budget(p: argparse.ArgumentParser) -> None:
    p.add_argument("--budget", action="append", default=[], metavar="NAME=VALUE",
                   help="raise or lower one of a run's budgets (repeatable): "
                        f"{', '.join(Budgets.names())}; docs/security.md")


# in the order ``labsim --help`` lists them
COMMANDS = (
    Command("run", "run a behaviour and print a summary", _run),
    Command("sweep", "run behaviours over a grid of parameters and seeds, in parallel, and compare the settings",
            _sweep),
    Command("grade", "grade a class's submissions against an assignment: a gradebook and a page for each student",
            _grade),
    Command("check", "check behaviour files without running them", _check),
    Command("test", "re-run behaviours and compare them with their golden traces", _test),
    Command("plot", "draw a trace: the map of a run, its signals against time, or an animation", _plot),
    Command("view", "watch and steer a run in the browser, or replay a trace", _view),
    Command("labs", "list the labs labsim ships (run one by name: labsim run wall_follow)", _labs),
    Command("new", "copy a lab and its golden trace into a folder, to edit and test", _new),
    Command("worlds", "list the built-in worlds", _worlds),
    Command("schema", "print the JSON Schema of behaviour, world or assignment files, for editors (docs/editors.md)",
            _schema),
    Command("export", "write a trace as an MCAP file, for Foxglove and Rerun (docs/mcap.md)", _export),
    Command("lsp", "a language server for editors: check-as-you-type, completion, hover (docs/editors.md)", _lsp),
    Command("serve", "stand in for CoppeliaSim: answer its ZMQ remote API from the embedded simulator", _serve),
    Command("scene", "build a behaviour's scene in a running CoppeliaSim (4.6 or newer)", _scene),
)
