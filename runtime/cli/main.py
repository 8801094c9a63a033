"""The ``labsim`` command line: run, check, test, plot, view, sweep, labs, new, worlds, serve.

A behaviour argument is a file, or the name of a lab labsim ships (``labsim run wall_follow``;
``labsim labs`` lists them, ``labsim new wall_follow`` copies one to edit).

Exit codes: 0 success; 1 a golden trace differs (or is missing); 2 a user's mistake (a bad
behaviour file, an unknown option or parameter, an unreachable simulator), reported as
``path:line:col: message`` without a Python traceback; 130 interrupted with Ctrl-C, 143 with
SIGTERM (handled as Ctrl-C: the trace so far is kept and closed, the summary printed).

Over 500 lines: one argparse declaration per command and option, and each command's short
function; the larger commands (plot, sweep, view, scene) keep their options in their own
modules.
"""
from __future__ import annotations

import argparse
import os
import signal
import sys
import threading
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, NoReturn

from labsim import __version__
from labsim.backends import DEFAULT, REGISTRY, load_backend
from labsim.backends.coppeliasim import DEFAULT_PORT
from labsim.backends.protocol import BackendError
from labsim.backends.scene.world import World
from labsim.backends.scene.world_names import builtin_worlds, find_world
from labsim.foundation import options
from labsim.foundation.diagnostics import Diagnostic, LabsimError, format_diagnostics
from labsim.foundation.files import ALLOW_ENV, allow, check_output, os_words, policy_problem
from labsim.foundation.kinds import GOLDEN_SUFFIX, file_kind
from labsim.foundation.limits import DEFAULT_BUDGETS, Budgets
from labsim.runtime.builder.command import add_scene_parser, cmd_scene
from labsim.runtime.cli.completion import autocomplete
from labsim.runtime.cli.report import ProgressBar, format_summary
from labsim.runtime.golden import check_golden, record_golden
from labsim.runtime.labs import LABS_DIR, behaviour_path, copy_lab, labs
from labsim.runtime.pictures.driver import add_plot_parser
from labsim.runtime.run import compile_behaviour
from labsim.runtime.summary_json import check_json_output, emit_json, summary_dict
from labsim.runtime.sweep.driver import add_sweep_parser
from labsim.runtime.trace import TraceFormatError, read_trace, slider_events

if TYPE_CHECKING:  # the stand-in server is imported only when `labsim serve` runs
    from labsim.runtime.serve.server import Server

EXIT_OK, EXIT_FAILED, EXIT_USAGE, EXIT_INTERRUPTED = 0, 1, 2, 130
EXIT_TERMINATED = 143  # 128 + SIGTERM, as a shell reports a process SIGTERM ended


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:
        self.print_usage(sys.stderr)
        sys.stderr.write(f"labsim: error: {message}\n")
        raise SystemExit(EXIT_USAGE)


def _parser() -> argparse.ArgumentParser:
    # long: one declaration per command and option, read top to bottom as the help is
    p = _Parser(prog="labsim", description="Run robotics labs written as behaviour files.")
    p.add_argument("--version", action="version", version=f"labsim {__version__}")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)

    run = sub.add_parser("run", help="run a behaviour and print a summary")
    run.add_argument("file", help="the behaviour file (.yaml), or a lab's name (labsim labs)")
    run.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                     help="override a parameter from the file's 'params:' (repeatable)")
    run.add_argument("--seed", type=int, help="override the file's seed")
    run.add_argument("--trace", metavar="PATH", help="write the trace (CSV) to PATH")
    run.add_argument("--replay", metavar="TRACE", help="move the sliders as a recorded trace did "
                                                       "(instead of the file's timeline)")
    run.add_argument("--backend", default=DEFAULT, choices=sorted(REGISTRY), help="simulator (default: %(default)s)")
    _remote_options(run)
    run.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                     help="show a progress bar (default: when stderr is a terminal)")
    run.add_argument("--quiet", "-q", action="store_true", help="print no summary")
    run.add_argument("--json", nargs="?", const="-", default=None, metavar="PATH|-",
                     help="write the summary as JSON to PATH; with - or no PATH to standard output, instead of "
                          "the text summary (docs/summary-json.md)")

    add_sweep_parser(sub)

    check = sub.add_parser("check", help="check behaviour files without running them")
    check.add_argument("files", nargs="+")
    check.add_argument("--show-code", action="store_true",
                       help="print the Python each file compiles to, each rule, signal and metric "
                            "under a comment with its line in the file")

    test = sub.add_parser("test", help="re-run behaviours and compare them with their golden traces")
    test.add_argument("paths", nargs="*", default=None,
                      help="behaviour files, folders or lab names (default: ./behaviours if there is "
                           "one, else the labs labsim ships)")
    test.add_argument("--update-goldens", action="store_true", help="record the golden traces anew")
    test.add_argument("--backend", default=DEFAULT, choices=sorted(REGISTRY),
                      help="simulator to re-run them on (default: %(default)s)")
    _remote_options(test)

    add_plot_parser(sub)

    view = sub.add_parser("view", help="watch and steer a run in the browser, or replay a trace")
    view.add_argument("file", help="a behaviour file (.yaml), or a trace (.csv) to replay")
    view.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                      help="override a parameter from the file's 'params:' (repeatable)")
    view.add_argument("--seed", type=int, help="override the file's seed")
    view.add_argument("--backend", default=DEFAULT, choices=sorted(REGISTRY), help="simulator (default: %(default)s)")
    view.add_argument("--host", type=options.host, default="127.0.0.1",
                      help="address to serve the page on (default: %(default)s, this computer only)")
    view.add_argument("--port", type=options.port, default=8765, help="port to serve the page on; 0 picks a free one "
                                                            "(default: %(default)s)")
    view.add_argument("--trace", metavar="PATH", help="record the live run, slider moves included, to PATH")
    view.add_argument("--no-browser", action="store_true", help="print the URL only; do not open a browser")
    view.add_argument("--sim-host", type=options.host, default=None,
                      help="CoppeliaSim's address, with --backend coppeliasim (default: 127.0.0.1)")
    view.add_argument("--sim-port", type=options.port, default=None,
                      help=f"CoppeliaSim's ZMQ remote API port, with --backend coppeliasim (default: {DEFAULT_PORT})")
    view.add_argument("--sim-timeout", type=options.timeout_s, default=None, metavar="SECONDS",
                      help="give up when CoppeliaSim does not answer within this (default: 5)")

    sub.add_parser("labs", help="list the labs labsim ships (run one by name: labsim run wall_follow)")
    new = sub.add_parser("new", help="copy a lab and its golden trace into a folder, to edit and test")
    new.add_argument("lab", help="the lab's name (labsim labs lists them)")
    new.add_argument("folder", nargs="?", default=".", help="where to put it (default: this folder)")

    sub.add_parser("worlds", help="list the built-in worlds")
    schema = sub.add_parser("schema", help="print the JSON Schema of behaviour or world files, for editors "
                                           "(docs/editors.md)")
    schema.add_argument("kind", choices=("behaviour", "world"))

    serve = sub.add_parser("serve", help="stand in for CoppeliaSim: answer its ZMQ remote API from the "
                                         "embedded simulator")
    serve.add_argument("world", nargs="?", default=None,
                       help="a built-in world (labsim worlds) or a world file (default: walls_lab4, "
                            "or the world of --for)")
    serve.add_argument("--port", type=options.port, default=DEFAULT_PORT,
                       help="port to listen on; 0 picks a free one (default: %(default)s)")
    serve.add_argument("--host", type=options.host, default="127.0.0.1",
                       help="address to listen on (default: %(default)s, this computer only)")
    serve.add_argument("--robots", type=options.robots, default=None, metavar="N",
                       help="Pioneer P3DX robots, at the world's spawn poses (default: 1; 0 for a "
                            "world with a mechanism)")
    serve.add_argument("--dt", type=options.time_step_s, default=None, metavar="SECONDS",
                       help="simulation time step (default: 0.05, CoppeliaSim's, or the dt of --for)")
    serve.add_argument("--for", dest="behaviour", metavar="FILE",
                       help="serve the scene a behaviour file needs: its world, dt and robots, with "
                            "their cameras")
    serve.add_argument("--quiet", "-q", action="store_true", help="do not log clients and simulations")
    serve.add_argument("--empty", action="store_true",
                       help="start from an empty scene, to be built through the remote API (labsim scene)")
    add_scene_parser(sub)
    for command in (run, sub.choices["sweep"], check, test, view):
        command.add_argument("--strict", action="store_true",
                             help="treat the behaviour files' warnings as errors (exit code 2)")
    for command in (run, sub.choices["sweep"], check, test, view, serve, sub.choices["plot"], sub.choices["scene"]):
        command.add_argument("--allow-path", action="append", default=[], metavar="DIR",
                             help="let behaviour files and traces read files in DIR too, not only in "
                                  "their own folder (repeatable; docs/security.md)")
    for command in (run, sub.choices["sweep"], check):
        command.add_argument("--budget", action="append", default=[], metavar="NAME=VALUE",
                             help="raise or lower one of a run's budgets (repeatable): "
                                  f"{', '.join(Budgets.names())}; docs/security.md")
    return p


def _remote_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--host", type=options.host, default=None, help="CoppeliaSim's address, with --backend coppeliasim "
                                                "(default: 127.0.0.1)")
    p.add_argument("--port", type=options.port, default=None,
                   help=f"CoppeliaSim's ZMQ remote API port, with --backend coppeliasim (default: {DEFAULT_PORT})")
    p.add_argument("--timeout", type=options.timeout_s, default=None, metavar="SECONDS",
                   help="give up when CoppeliaSim does not answer within this, with --backend coppeliasim "
                        "(default: 5)")


def _backend_options(args: argparse.Namespace) -> dict[str, object]:
    """--host/--port/--timeout as options of the chosen backend (only coppeliasim takes them)."""
    given = {k: v for k, v in (("host", args.host), ("port", args.port), ("timeout_s", args.timeout))
             if v is not None}
    if args.backend != "coppeliasim":
        if given:
            flags = ", ".join("--" + k.removesuffix("_s") for k in given)
            raise LabsimError([Diagnostic(flags, f"only --backend coppeliasim takes {flags}")])
        return {}
    if args.timeout is not None and not args.timeout > 0:
        raise LabsimError([Diagnostic("--timeout", "give a positive number of seconds")])
    return given


def main(argv: Sequence[str] | None = None) -> int:
    parser = _parser()
    autocomplete(parser)  # answers the shell's Tab and exits, when the shell is asking
    args = parser.parse_args(argv)
    _terminate_like_ctrl_c()
    allowed = os.environ.get(ALLOW_ENV)
    try:
        _allow_paths(getattr(args, "allow_path", []))
        _name_labs(args)
        if getattr(args, "strict", False) and args.command in ("test", "view", "sweep"):
            _strict(args)
        code = {"run": cmd_run, "check": cmd_check, "test": cmd_test, "plot": cmd_plot, "view": cmd_view,
                "labs": cmd_labs, "new": cmd_new, "worlds": cmd_worlds, "serve": cmd_serve,
                "sweep": cmd_sweep, "schema": cmd_schema, "scene": cmd_scene}[args.command](args)
        return EXIT_TERMINATED if code == EXIT_INTERRUPTED and _terminated() else code
    except LabsimError as e:
        _print_diagnostics(e.diagnostics)
        return EXIT_USAGE
    except BackendError as e:
        sys.stderr.write(f"labsim: error: {e}\n")
        return EXIT_USAGE
    except KeyboardInterrupt:
        sys.stderr.write("labsim: terminated\n" if _terminated() else "labsim: interrupted\n")
        return EXIT_TERMINATED if _terminated() else EXIT_INTERRUPTED
    except BrokenPipeError:  # `labsim run ... | head`: the reader has what it wanted
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_OK
    except OSError as e:  # what the file system said about a path no reader checked first
        where = str(e.filename) if e.filename is not None else "labsim"
        sys.stderr.write(f"{where}: error: {os_words(e)}\n")
        return EXIT_USAGE
    finally:  # --allow-path holds for this command (and the processes it started) only
        if allowed is None:
            os.environ.pop(ALLOW_ENV, None)
        else:
            os.environ[ALLOW_ENV] = allowed


class Terminated(KeyboardInterrupt):
    """SIGTERM, handled as Ctrl-C is (the trace closed, the remote simulation stopped, the summary
    shown), with its own exit code (docs/security.md)."""


def _terminate_like_ctrl_c() -> None:
    def handler(signum: int, frame: object) -> None:
        global _TERMINATED
        _TERMINATED = True
        raise Terminated

    if threading.current_thread() is threading.main_thread():  # signals reach the main thread only
        signal.signal(signal.SIGTERM, handler)


def _terminated() -> bool:
    return _TERMINATED


_TERMINATED = False


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
    if getattr(args, "files", None):
        args.files = [str(behaviour_path(f)) for f in args.files]
    if getattr(args, "behaviour", None):
        args.behaviour = str(behaviour_path(args.behaviour))
    if args.command == "test":
        if not args.paths:
            args.paths = ["behaviours"] if Path("behaviours").is_dir() else [str(LABS_DIR)]
        args.paths = [str(behaviour_path(p)) for p in args.paths]


def _print_diagnostics(diagnostics: list[Diagnostic]) -> None:
    for text in format_diagnostics(diagnostics):  # at most MAX_PER_FILE a file
        sys.stderr.write(text + "\n")
    errors = sum(d.severity == "error" for d in diagnostics)
    if errors > 1:
        sys.stderr.write(f"{errors} errors\n")


def _strict(args: argparse.Namespace) -> None:
    """--strict: every behaviour the command will run compiles without warnings, or LabsimError."""
    if args.command == "test":
        files = _behaviour_files(args.paths)
    elif args.command == "view":
        files = [] if file_kind(args.file) in ("trace", "golden") else [Path(args.file)]
    else:
        files = [Path(f) for f in args.files]
    overrides = _overrides(args.set) if args.command == "view" else {}  # a sweep's --set is a grid
    problems: list[Diagnostic] = []
    for f in files:
        try:
            compile_behaviour(f, overrides, strict=True)
        except LabsimError as e:
            problems += e.diagnostics
    if problems:
        raise LabsimError(problems)


def budgets(args: argparse.Namespace) -> Budgets:
    """The run's budgets: the defaults, with the command line's --budget NAME=VALUE."""
    out, problems = DEFAULT_BUDGETS.parse(getattr(args, "budget", None) or [])
    if problems:
        raise LabsimError([Diagnostic(where, message) for where, message in problems])
    return out


def _overrides(pairs: list[str]) -> dict[str, str]:
    out = {}
    for pair in pairs:
        name, eq, value = pair.partition("=")
        if not eq or not name.strip():
            raise LabsimError([Diagnostic(f"--set {pair}", "--set takes NAME=VALUE, e.g. --set front=1.0")])
        out[name.strip()] = value.strip()
    return out


def _warn(message: str) -> None:
    sys.stderr.write("\r" + message + "\n")


def cmd_run(args: argparse.Namespace) -> int:
    overrides = _overrides(args.set)
    if args.seed is not None and args.seed < 0:
        raise LabsimError([Diagnostic("--seed", "the seed is 0 or a positive whole number")])
    behaviour = compile_behaviour(args.file, overrides, seed=args.seed, strict=args.strict,
                                  budgets=budgets(args))
    if behaviour.program.warnings:  # before the run, which may take a while
        _print_diagnostics(list(behaviour.program.warnings))
    if args.trace:
        _check_writable(args.trace, [Path(args.file), Path(behaviour.program.world.source)])
    if args.json not in (None, "-"):
        check_json_output(args.json, [Path(args.file), Path(behaviour.program.world.source)])
    replay = None
    if args.replay:
        try:
            recorded = read_trace(args.replay)
            replay = slider_events(recorded)
        except TraceFormatError as e:
            raise LabsimError([e.diagnostic(args.replay)]) from None
        if recorded.cut_short():
            _warn(f"{args.replay}: warning: {recorded.cut_short()}; replaying the moves it has")
    backend = load_backend(args.backend, **_backend_options(args))
    warnings: list[str] = []

    def warn(message: str) -> None:
        warnings.append(message)
        _warn(message)

    run = behaviour.bind(backend, trace=args.trace, warn=warn, replay=replay)
    show = args.progress if args.progress is not None else sys.stderr.isatty()
    bar = ProgressBar(behaviour.program.stop_horizon_s) if show else None
    try:
        summary = run.run(progress=bar)
    finally:
        if bar is not None:
            bar.clear()
        run.close()
    unwritten: LabsimError | None = run.trace_error
    if args.json is not None:
        try:
            emit_json(summary_dict(summary, run, warnings=warnings), args.json)
        except LabsimError as e:  # a full disk: the text summary below still shows the run
            unwritten = unwritten or e
    if not args.quiet and args.json != "-":
        print(format_summary(summary, run))
        trips = _round_trips(backend, summary.ticks)
        if trips:
            print(trips)
    # after the summary: what the run did up to there is worth seeing, and is not lost with a file
    if summary.over_budget:
        sys.stderr.write(f"{args.file}: error: {summary.over_budget}\n")
    if unwritten is not None:
        raise unwritten
    if summary.over_budget:
        return EXIT_USAGE
    return EXIT_INTERRUPTED if summary.interrupted else EXIT_OK


def _round_trips(backend: object, ticks: int) -> str:
    """A remote backend's requests per tick (what bounds its speed), or '' for an embedded one."""
    total = getattr(backend, "round_trips", None)
    if not isinstance(total, int) or not ticks:
        return ""
    during = total - getattr(backend, "round_trips_open", 0)
    where = getattr(backend, "where", "")
    return (f"  {during / ticks:.2f} round trips per tick"
            f" ({total} requests in all{' to ' + where if where else ''})")


def _check_writable(path: str, inputs: list[Path]) -> None:
    """The one way out (foundation/files.py): a regular file, none of the run's inputs."""
    check_output(path, inputs, "--trace")


def cmd_check(args: argparse.Namespace) -> int:
    """Compile each file and report its problems; with --show-code, print its Python instead of 'ok'."""
    problems: list[Diagnostic] = []
    for f in args.files:
        try:
            behaviour = compile_behaviour(f, strict=args.strict, budgets=budgets(args))
            problems += behaviour.program.warnings
            warned = len(behaviour.program.warnings)
            print(behaviour.program.code.listing if args.show_code else
                  f"{f}: ok" + (f" ({warned} warning{'s' * (warned > 1)})" if warned else ""))
        except LabsimError as e:
            problems += e.diagnostics
    if problems:
        _print_diagnostics(problems)
    return EXIT_USAGE if any(d.severity == "error" for d in problems) else EXIT_OK


def _behaviour_files(paths: list[str]) -> list[Path]:
    files: list[Path] = []
    for p in map(Path, paths):
        if p.is_dir():
            found = sorted(p.glob("*.yaml"))
            _refuse_links_out(p, found + sorted(p.glob("*" + GOLDEN_SUFFIX)))
            files += [f for f in found if file_kind(f) != "world"]  # labsim test skips world files
        elif p.exists():
            files.append(p)
        else:
            raise LabsimError([Diagnostic(str(p), "no such file or folder")])
    return files


def _refuse_links_out(folder: Path, found: list[Path]) -> None:
    """A file found in a folder is that folder's: a link out of it is refused (docs/security.md)."""
    problems = [Diagnostic(str(f), f"{refused}; labsim test reads files found in a folder only inside it "
                                   "(or in an --allow-path DIR)")
                for f in found if (refused := policy_problem(f.name, folder))]
    if problems:
        raise LabsimError(problems)


def cmd_test(args: argparse.Namespace) -> int:
    files = _behaviour_files(args.paths)
    if not files:
        raise LabsimError([Diagnostic(" ".join(args.paths), "no behaviour files (*.yaml) here")])
    options = _backend_options(args)
    if args.update_goldens and args.backend != DEFAULT:
        raise LabsimError([Diagnostic("--update-goldens", f"goldens are recorded on the {DEFAULT} backend; "
                                      f"drop --backend {args.backend}")])
    failed = bad = 0
    for f in files:
        try:
            ok = _test_one(f, args, options)
        except LabsimError as e:  # a broken behaviour: say why, and test the others
            print(f"FAIL {f}: it does not compile (errors below)")
            _print_diagnostics(e.diagnostics)
            bad += 1
            continue
        failed += not ok
    print(f"{len(files) - failed - bad} passed, {failed + bad} failed")
    return EXIT_USAGE if bad else EXIT_FAILED if failed else EXIT_OK


def _test_one(f: Path, args: argparse.Namespace, options: dict[str, object]) -> bool:
    """Record, or compare with, one behaviour's golden; False when it fails."""
    if args.update_goldens:
        compile_behaviour(f)  # a broken file is reported as broken before anything is written
        golden, summary = record_golden(f, args.backend, options)
        print(f"recorded {golden} ({summary.ticks} ticks)")
        return True
    verdict = check_golden(f, args.backend, options)
    print(verdict)
    return verdict.passed


def cmd_plot(args: argparse.Namespace) -> int:
    """The map, a signals chart or an animation of a trace; runtime/pictures/driver.py."""
    from labsim.runtime.pictures.driver import run_plot

    return run_plot(args)


def cmd_view(args: argparse.Namespace) -> int:
    """Serve the page of a live run or a replayed trace until Ctrl-C; see docs/view.md."""
    from labsim.runtime.view import view

    if args.trace:
        _check_writable(args.trace, [Path(args.file)])
    # --host and --port are the page's; CoppeliaSim's address has options of its own here
    options: dict[str, object] = {k: v for k, v in (("host", args.sim_host), ("port", args.sim_port),
                                                    ("timeout_s", args.sim_timeout)) if v is not None}
    if options and args.backend != "coppeliasim":
        flags = ", ".join("--sim-" + k.removesuffix("_s") for k in options)
        raise LabsimError([Diagnostic(flags, f"only --backend coppeliasim takes {flags}")])
    if args.sim_timeout is not None and not args.sim_timeout > 0:
        raise LabsimError([Diagnostic("--sim-timeout", "give a positive number of seconds")])
    return view(args.file, overrides=_overrides(args.set), seed=args.seed, backend=args.backend,
                backend_options=options, host=args.host, port=args.port, trace=args.trace,
                open_browser=not args.no_browser, warn=_warn, report=_print_diagnostics)


def cmd_sweep(args: argparse.Namespace) -> int:
    """Run a grid of runs and compare the settings; runtime/sweep/driver.py."""
    from labsim.runtime.sweep.driver import run_sweep, sweep_options

    return run_sweep(sweep_options(args))


def cmd_labs(args: argparse.Namespace) -> int:
    for lab in labs().values():
        print(f"{lab.name:<14} {lab.title}")
    print("\nrun one with: labsim run NAME;  copy one to edit: labsim new NAME [FOLDER]")
    return EXIT_OK


def cmd_new(args: argparse.Namespace) -> int:
    folder = Path(args.folder)
    written = copy_lab(args.lab, folder)
    for path in written:
        print(f"wrote {path}")
    behaviour = written[0]
    print(f"\nnext: labsim run {behaviour}      (edit it, then: labsim test {behaviour}; "
          f"after a deliberate change: labsim test {behaviour} --update-goldens)")
    return EXIT_OK


def cmd_worlds(args: argparse.Namespace) -> int:
    from labsim.backends.scene.world_file import load_world
    from labsim.foundation.diagnostics import Report

    for name, path in builtin_worlds().items():
        world = load_world(path, Report())
        print(f"{name:<16} {world.description if world else '(damaged world file)'}")
    return EXIT_OK


def cmd_schema(args: argparse.Namespace) -> int:
    from labsim.runtime.cli.schemas import schema_text

    sys.stdout.write(schema_text(args.kind))
    return EXIT_OK


def cmd_serve(args: argparse.Namespace) -> int:
    """Serve CoppeliaSim's ZMQ remote API until Ctrl-C; see docs/coppeliasim.md."""
    from labsim.backends.protocol import RobotRequest
    from labsim.runtime.serve.server import Server, serve

    requests: list[RobotRequest] | None = None
    world = None
    dt = args.dt
    if args.behaviour is not None:
        program = compile_behaviour(args.behaviour).program
        world = program.world
        dt = dt if dt is not None else program.dt_s
        # the behaviour's robots (models with their cameras); the backend places them itself
        models = [group.model for group in program.robots for _ in range(group.count)]
        poses = [pose for _, pose in Server.robot_specs(world, len(models))]
        requests = [RobotRequest(f"PioneerP3DX[{i}]", m, pose, ()) for i, (m, pose) in enumerate(zip(models, poses))]
    if args.world is not None or world is None:
        world = _load_world_arg(args.world or "walls_lab4")
    robots: int | list[RobotRequest]
    if requests is not None and args.robots is None:
        robots = requests
    else:
        robots = args.robots if args.robots is not None else (0 if world.mechanism is not None else 1)
        if robots < 0:
            raise LabsimError([Diagnostic("--robots", "give 0 or more robots")])
    dt = dt if dt is not None else 0.05
    if not 0 <= args.port < 65536:
        raise LabsimError([Diagnostic("--port", "give a port from 1 to 65535, or 0 for a free one")])
    if not dt > 0:
        raise LabsimError([Diagnostic("--dt", "give a positive time step in seconds")])

    def ready(server: Server) -> None:
        what = ("an empty scene (labsim scene FILE builds one)" if args.empty
                else f"world {world.name} ({server.describe()})")
        print(f"labsim serve: {what}, dt {dt:g} s, listening on "
              f"tcp://{args.host}:{server.port}; Ctrl-C stops", flush=True)

    log = None if args.quiet else _warn
    serve(world, robots, args.port, args.host, dt_s=dt, log=log, ready=ready, empty=args.empty)
    print("labsim serve: stopped", flush=True)
    return EXIT_OK


def _load_world_arg(name: str) -> World:
    """A world named on the command line: built-in, or a world file."""
    from labsim.backends.scene.world_file import load_world
    from labsim.foundation.diagnostics import Report

    found = find_world(name)  # typed by the person running labsim: any path
    if found.path is None:
        raise LabsimError([Diagnostic(name, found.problem, notes=found.notes)])
    report = Report()
    world = load_world(found.path, report)
    if world is None:
        report.raise_if_errors()
        raise LabsimError([Diagnostic(str(found.path), "could not read this world")])
    return world


if __name__ == "__main__":
    raise SystemExit(main())
