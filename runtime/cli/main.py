"""The ``labsim`` command line: run, check, test, plot, view, sweep, grade, serve, scene, export, lsp, ...

A behaviour argument is a file, or the name of a lab labsim ships (``labsim run wall_follow``;
``labsim labs`` lists them, ``labsim new wall_follow`` copies one to edit).

``main`` parses the arguments (``labsim.runtime.cli.parser`` declares the options of the
command given, and only those), applies what every command shares (``--allow-path``, lab names,
``--strict``), runs the command (``labsim.runtime.cli.commands``) and turns what went wrong into
an exit code (``labsim.foundation.exits``): 0 success; 1 a golden trace differs (or is missing);
2 a user's mistake (a bad behaviour file, an unknown option or parameter, an unreachable
simulator), reported as ``path:line:col: message`` without a Python traceback; 130 interrupted
with Ctrl-C, 143 with SIGTERM and 129 with SIGHUP (both handled as Ctrl-C: the trace so far
is kept and closed, the summary printed).
"""
from __future__ import annotations

import argparse
import os
import signal
import sys
import threading
from collections.abc import Callable, Sequence
from pathlib import Path

from labsim.backends.protocol import BackendError
from labsim.foundation.diagnostics import Diagnostic, LabsimError
from labsim.foundation.exits import EXIT_HANGUP, EXIT_INTERRUPTED, EXIT_OK, EXIT_TERMINATED, EXIT_USAGE
from labsim.foundation.files import ALLOW_ENV, allow, missing_notes, os_words
from labsim.foundation.inert import inert
from labsim.foundation.kinds import file_kind
from labsim.foundation.threads import limit_blas_threads
from labsim.runtime.cli import commands
from labsim.runtime.cli.commands import behaviour_files, parse_overrides, print_diagnostics
from labsim.runtime.cli.parser import build_parser
from labsim.runtime.labs import LABS_DIR, behaviour_path

Command = Callable[[argparse.Namespace], int]


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command ``argv`` names (default: this process's arguments); its exit code."""
    if "_ARGCOMPLETE" in os.environ:  # the shell's Tab: answer from every command's options, and exit
        from labsim.runtime.cli.completion import autocomplete

        autocomplete(build_parser(argv, every=True))
    args = build_parser(argv).parse_args(argv)
    limit_blas_threads()  # before numpy is imported, by the command's run (and by its workers)
    _terminate_like_ctrl_c()
    allowed = os.environ.get(ALLOW_ENV)
    try:
        _allow_paths(getattr(args, "allow_path", []))
        _name_labs(args)
        if getattr(args, "seed", None) is not None and args.seed < 0:  # run and view: said once, before either starts
            raise LabsimError([Diagnostic("--seed", f"the seed is 0 or a positive whole number, not {args.seed}",
                                          notes=(commands.SEED_NOTE,))])
        if getattr(args, "strict", False) and args.command in ("test", "view", "sweep"):
            _strict(args)
        code = _command(args.command)(args)
        return _ended_by() if code == EXIT_INTERRUPTED and _terminated() else code
    except LabsimError as e:
        print_diagnostics(e.diagnostics)
        return EXIT_USAGE
    except BackendError as e:
        sys.stderr.write(f"labsim: error: {inert(str(e))}\n")
        return EXIT_USAGE
    except KeyboardInterrupt:
        sys.stderr.write(f"labsim: {_ENDED[1]}\n" if _terminated() else "labsim: interrupted\n")
        return _ended_by() if _terminated() else EXIT_INTERRUPTED
    except BrokenPipeError:  # `labsim run ... | head`: the reader has what it wanted
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_OK
    except OSError as e:  # what the file system said about a path no reader checked first
        where = str(e.filename) if e.filename is not None else "labsim"
        sys.stderr.write(f"{inert(where)}: error: {os_words(e)}\n")
        return EXIT_USAGE
    finally:  # --allow-path holds for this command (and the processes it started) only
        if allowed is None:
            os.environ.pop(ALLOW_ENV, None)
        else:
            os.environ[ALLOW_ENV] = allowed


def _command(name: str) -> Command:
    """The function that runs a command (``labsim.runtime.cli.parser.COMMANDS`` names them)."""
    return {"run": commands.cmd_run, "check": commands.cmd_check, "test": commands.cmd_test,
            "plot": commands.cmd_plot, "view": commands.cmd_view, "labs": commands.cmd_labs,
            "new": commands.cmd_new, "worlds": commands.cmd_worlds, "serve": commands.cmd_serve,
            "sweep": commands.cmd_sweep, "grade": commands.cmd_grade, "schema": commands.cmd_schema,
            "scene": commands.cmd_scene,
            "lsp": commands.cmd_lsp, "export": commands.cmd_export}[name]


class Terminated(KeyboardInterrupt):
    """SIGTERM, handled as Ctrl-C is (the trace closed, the remote simulation stopped, the summary
    shown), with its own exit code (docs/security.md)."""


def _terminate_like_ctrl_c() -> None:
    """SIGTERM, and SIGHUP (the terminal closed), end a command as Ctrl-C does, each with its code."""
    def handler(signum: int, frame: object) -> None:
        _ENDED[:] = [EXIT_HANGUP, "hung up"] if signum == getattr(signal, "SIGHUP", None) else [
            EXIT_TERMINATED, "terminated"]
        raise Terminated

    if threading.current_thread() is threading.main_thread():  # signals reach the main thread only
        signal.signal(signal.SIGTERM, handler)
        if hasattr(signal, "SIGHUP"):  # not on Windows
            signal.signal(signal.SIGHUP, handler)


def _terminated() -> bool:
    return bool(_ENDED)


def _ended_by() -> int:
    return int(_ENDED[0])


_ENDED: list = []  # the exit code and word of the signal that ended the command, once one has


def _allow_paths(folders: list[str]) -> None:
    """--allow-path DIR: folders files may name besides their own (docs/security.md)."""
    for folder in folders:
        if not Path(folder).is_dir():
            raise LabsimError([Diagnostic(f"--allow-path {folder}", "is not a folder")])
    allow(folders)


def _name_labs(args: argparse.Namespace) -> None:
    """Behaviour arguments that name a lab (``wall_follow``) become that lab's file."""
    if getattr(args, "file", None) is not None:
        args.file = str(behaviour_path(args.file))
        if args.command == "view" and not os.path.lexists(args.file):  # a behaviour, a trace or a golden
            kind = "trace" if args.file.lower().endswith(".csv") else "behaviour"
            raise LabsimError([Diagnostic(args.file, "no such file", notes=missing_notes(args.file, kind))])
    if getattr(args, "files", None):
        args.files = [str(behaviour_path(f)) for f in args.files]
    if getattr(args, "behaviour", None):
        args.behaviour = str(behaviour_path(args.behaviour))
    if args.command == "test":
        if not args.paths:
            args.paths = ["behaviours"] if Path("behaviours").is_dir() else [str(LABS_DIR)]
        args.paths = [str(behaviour_path(p)) for p in args.paths]


def _strict(args: argparse.Namespace) -> None:
    """--strict: every behaviour the command will run compiles without warnings, or LabsimError."""
    from labsim.runtime.run import compile_behaviour

    if args.command == "test":
        files = behaviour_files(args.paths)
    elif args.command == "view":
        files = [] if file_kind(args.file) in ("trace", "golden") else [Path(args.file)]
    else:
        files = [Path(f) for f in args.files]
    overrides = parse_overrides(args.set) if args.command == "view" else {}  # a sweep's --set is a grid
    problems: list[Diagnostic] = []
    for f in files:
        try:
            compile_behaviour(f, overrides, strict=True)
        except LabsimError as e:
            problems += e.diagnostics
    if problems:
        raise LabsimError(problems)


if __name__ == "__main__":
    raise SystemExit(main())
