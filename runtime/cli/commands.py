"""The ``labsim`` commands: what each one does with its parsed options, and its exit code.

``labsim.runtime.cli.main`` parses the command line and calls one of these. The commands on
the tick loop (run, check, test) and the small ones (labs, new, worlds, schema) are here whole;
the applications' commands (plot, view, sweep, serve, scene) check what only the command line
knows and hand over to their application, which each imports only when it runs, so that no
command pays for another's imports (matplotlib, OpenCV's drawing, aiohttp, Dask, ZMQ). The
compiler too is imported by the commands that compile (``labsim.runtime.run.compile_behaviour``):
lark, the checker and the code generator are a quarter of a second of start-up that ``plot``
of a trace, ``labs`` and ``worlds`` need not pay.
A user's mistake is a ``LabsimError``, which ``main`` reports with exit code 2.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from labsim.backends import DEFAULT, load_backend
from labsim.backends.scene.world import World
from labsim.backends.scene.world_names import builtin_worlds, find_world
from labsim.foundation.diagnostics import Diagnostic, LabsimError, diagnostics_json, format_diagnostics
from labsim.foundation.exits import EXIT_FAILED, EXIT_INTERRUPTED, EXIT_OK, EXIT_USAGE
from labsim.foundation.files import check_output, missing_notes, policy_problem
from labsim.foundation.inert import inert
from labsim.foundation.kinds import GOLDEN_SUFFIX, file_kind
from labsim.foundation.limits import DEFAULT_BUDGETS, Budgets
from labsim.runtime.hands import hand_events
from labsim.runtime.labs import copy_lab, labs
from labsim.runtime.trace import TraceFormatError, read_trace, slider_events

if TYPE_CHECKING:  # the stand-in server is imported only when `labsim serve` runs
    from labsim.dsl.emit.program import Program
    from labsim.runtime.breakpoint import BreakObserver
    from labsim.runtime.serve.server import Server


# -- what several commands share -----------------------------------------------------------------

def print_diagnostics(diagnostics: list[Diagnostic]) -> None:
    """The diagnostics on stderr (at most a few a file), and how many errors when more than one."""
    for text in format_diagnostics(diagnostics):  # at most MAX_PER_FILE a file
        sys.stderr.write(text + "\n")
    errors = sum(d.severity == "error" for d in diagnostics)
    if errors > 1:
        sys.stderr.write(f"{errors} errors\n")


def print_warning(message: str) -> None:
    """One line on stderr, over a progress bar that may be showing there; a log's or a warning's
    file text inert (foundation/inert.py)."""
    sys.stderr.write("\r" + inert(message) + "\n")


def parse_overrides(pairs: list[str]) -> dict[str, str]:
    """--set NAME=VALUE, each pair as a parameter override; the values as given (the checker reads them)."""
    out = {}
    for pair in pairs:
        name, eq, value = pair.partition("=")
        if not eq or not name.strip():
            raise LabsimError([Diagnostic(f"--set {pair}", "--set takes NAME=VALUE, e.g. --set front=1.0")])
        out[name.strip()] = value.strip()
    return out


def budgets(args: argparse.Namespace) -> Budgets:
    """The run's budgets: the defaults, with the command line's --budget NAME=VALUE."""
    out, problems = DEFAULT_BUDGETS.parse(getattr(args, "budget", None) or [])
    if problems:
        raise LabsimError([Diagnostic(where, message) for where, message in problems])
    return out


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


# -- the commands on the tick loop ---------------------------------------------------------------

def _replayed(path: str | None) -> tuple[Any, Any]:
    """``--replay TRACE``: the slider moves and the hands' moves the trace recorded (or none)."""
    if not path:
        return None, None
    try:
        recorded = read_trace(path)
        moves = slider_events(recorded), hand_events(recorded)
    except TraceFormatError as e:
        raise LabsimError([e.diagnostic(path)]) from None
    if recorded.cut_short():
        print_warning(f"{path}: warning: {recorded.cut_short()}; replaying the moves it has")
    return moves


# what a seed is, for a --seed refused: the same seed gives the same run
SEED_NOTE = ("a seed picks the run's random draws (the same seed, the same run): --seed 0, --seed 1, ...; "
             "without --seed, the file's seed: is used")


def cmd_run(args: argparse.Namespace) -> int:
    from labsim.runtime.cli.mcap_run import export_run, mcap_trace
    from labsim.runtime.cli.report import ProgressBar, format_summary
    from labsim.runtime.run import compile_behaviour
    from labsim.runtime.summary_json import check_json_output, emit_json, summary_dict

    overrides = parse_overrides(args.set)
    if args.seed is not None and args.seed < 0:  # main refuses it first; here for a caller of cmd_run itself
        raise LabsimError([Diagnostic("--seed", f"the seed is 0 or a positive whole number, not {args.seed}",
                                      notes=(SEED_NOTE,))])
    behaviour = compile_behaviour(args.file, overrides, seed=args.seed, strict=args.strict, budget=budgets(args))
    if behaviour.program.warnings:  # before the run, which may take a while
        print_diagnostics(list(behaviour.program.warnings))
    # every input of the run: the behaviour, its world file and the trace it replays
    inputs = [Path(args.file), Path(behaviour.program.world.source), *([Path(args.replay)] if args.replay else [])]
    mcap_out = mcap_trace(args, inputs)  # --trace run.mcap: the CSV trace first, beside it, then exported
    if args.json not in (None, "-"):
        check_json_output(args.json, inputs)
    replay, hands = _replayed(args.replay)
    stopper = _break_observer(behaviour.program, args)
    backend = load_backend(args.backend, **_backend_options(args))
    if args.backend == "pymunk":
        from labsim.runtime.cli.parser import note_without_kernel
        note_without_kernel()
    run = behaviour.bind(backend, trace=args.trace, warn=print_warning, replay=replay, hands=hands,
                         observers=[stopper] if stopper is not None else [])
    show = args.progress if args.progress is not None else sys.stderr.isatty()
    bar = ProgressBar(behaviour.program.stop_horizon_s) if show else None
    try:
        summary = run.run(progress=bar)
    finally:
        if bar is not None:
            bar.clear()
        run.close()
    unwritten: LabsimError | None = run.trace_error
    if mcap_out is not None and unwritten is None:
        unwritten = export_run(args.trace, mcap_out)
    if args.json is not None:
        try:
            emit_json(summary_dict(summary), args.json)
        except LabsimError as e:  # a full disk: the text summary below still shows the run
            unwritten = unwritten or e
    if stopper is not None:
        from labsim.runtime.breakpoint import break_report
        print(break_report(args.break_when, stopper.hit, stopper.last, summary.dt_s))
    if not args.quiet and args.json != "-" and (stopper is None or stopper.hit is None):
        print(format_summary(summary))
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


def _break_observer(program: Program, args: argparse.Namespace) -> BreakObserver | None:
    """``--break COND``: the condition compiled as a view's breakpoint is (labsim.dsl.watch)."""
    if args.break_when is None:
        return None
    from labsim.dsl.watch import compile_watch
    from labsim.runtime.breakpoint import BreakObserver

    if args.json is not None:
        raise LabsimError([Diagnostic("--break", "a run stopped at a breakpoint has no summary to write as JSON: "
                                                 "leave out --json or --break")])
    return BreakObserver(compile_watch(program, args.break_when))


def _round_trips(backend: object, ticks: int) -> str:
    """A remote backend's requests per tick (what bounds its speed), or '' for an embedded one."""
    total = getattr(backend, "round_trips", None)
    if not isinstance(total, int) or not ticks:
        return ""
    during = total - getattr(backend, "round_trips_open", 0)
    where = getattr(backend, "where", "")
    return (f"  {during / ticks:.2f} round trips per tick"
            f" ({total} requests in all{' to ' + where if where else ''})")


def cmd_check(args: argparse.Namespace) -> int:
    """Compile each file and report its problems; with --show-code, print its Python instead of 'ok';
    with --json, every diagnostic as JSON on stdout (``diagnostics_json``)."""
    from labsim.runtime.run import compile_behaviour

    problems: list[Diagnostic] = []
    for f in args.files:
        try:
            behaviour = compile_behaviour(f, strict=args.strict, budget=budgets(args))
            problems += behaviour.program.warnings
            warned = len(behaviour.program.warnings)
            if not args.json:
                print(behaviour.program.code.listing if args.show_code else
                      f"{inert(f)}: ok" + (f" ({warned} warning{'s' * (warned > 1)})" if warned else ""))
        except LabsimError as e:
            problems += e.diagnostics
    if args.json:
        sys.stdout.write(json.dumps(diagnostics_json(args.files, problems), indent=2) + "\n")
    elif problems:
        print_diagnostics(problems)
    return EXIT_USAGE if any(d.severity == "error" for d in problems) else EXIT_OK


def cmd_test(args: argparse.Namespace) -> int:
    files = behaviour_files(args.paths)
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
            print(f"FAIL {inert(str(f))}: it does not compile (errors below)")
            print_diagnostics(e.diagnostics)
            bad += 1
            continue
        failed += not ok
    print(f"{len(files) - failed - bad} passed, {failed + bad} failed")
    return EXIT_USAGE if bad else EXIT_FAILED if failed else EXIT_OK


def _test_one(f: Path, args: argparse.Namespace, options: dict[str, object]) -> bool:
    """Record, or compare with, one behaviour's golden; False when it fails."""
    from labsim.runtime.golden import check_golden, record_golden
    from labsim.runtime.run import compile_behaviour

    if args.update_goldens:
        compile_behaviour(f)  # a broken file is reported as broken before anything is written
        golden, summary = record_golden(f, args.backend, options)
        print(f"recorded {inert(str(golden))} ({summary.ticks} ticks)")
        return True
    verdict = check_golden(f, args.backend, options)
    print("\n".join(inert(line) for line in verdict.lines))  # a golden's cells are a file's text
    return verdict.passed


def behaviour_files(paths: list[str]) -> list[Path]:
    files: list[Path] = []
    for p in map(Path, paths):
        if p.is_dir():
            found = sorted(p.glob("*.yaml"))
            _refuse_links_out(p, found + sorted(p.glob("*" + GOLDEN_SUFFIX)))
            files += [f for f in found if file_kind(f) != "world"]  # labsim test skips world files
        elif p.exists():
            files.append(p)
        else:
            raise LabsimError([Diagnostic(str(p), "no such file or folder", notes=missing_notes(p, "behaviour"))])
    return files


def _refuse_links_out(folder: Path, found: list[Path]) -> None:
    """A file found in a folder is that folder's: a link out of it is refused (docs/security.md)."""
    problems = [Diagnostic(str(f), f"{refused}; labsim test reads files found in a folder only inside it "
                                   "(or in an --allow-path DIR)")
                for f in found if (refused := policy_problem(f.name, folder))]
    if problems:
        raise LabsimError(problems)


def cmd_labs(args: argparse.Namespace) -> int:
    found = labs()
    width = max((len(name) for name in found), default=0)  # the longest name sets the column
    for lab in found.values():
        print(f"{lab.name:<{width}}  {lab.title}")
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

    found = builtin_worlds()
    width = max((len(name) for name in found), default=0)
    for name, path in found.items():
        world = load_world(path, Report())
        print(f"{name:<{width}}  {world.description if world else '(damaged world file)'}")
    return EXIT_OK


def cmd_schema(args: argparse.Namespace) -> int:
    from labsim.runtime.cli.schemas import schema_text

    sys.stdout.write(schema_text(args.kind))
    return EXIT_OK


# -- the applications' commands: each imports its application when it runs ----------------------

def cmd_plot(args: argparse.Namespace) -> int:
    """The map, a signals chart or an animation of a trace; runtime/pictures/driver.py."""
    from labsim.runtime.pictures.driver import run_plot

    return run_plot(args)


def cmd_export(args: argparse.Namespace) -> int:
    """A trace as an MCAP file (runtime/export/mcap_file.py; docs/mcap.md)."""
    from labsim.runtime.export.mcap_file import export_trace

    done = export_trace(args.trace, args.output)
    robots = len(done.robots)
    print(f"wrote {inert(args.output)}: {robots} robot{'s' * (robots != 1)}, {done.ticks} ticks, "
          f"{done.messages} messages")
    if done.cut_short:
        print_warning(f"{args.trace}: warning: {done.cut_short}; exported as far as it goes")
    if done.world_note:
        print_warning(f"{args.trace}: warning: {done.world_note.replace('drawn', 'exported')}")
    return EXIT_OK


def cmd_lsp(args: argparse.Namespace) -> int:
    """The language server over stdio until the editor says exit (runtime/lsp/server.py); the
    assignment files' reader and schema are the grader's, handed in from here."""
    from labsim.runtime.grade.assignment_schema import assignment_schema
    from labsim.runtime.lsp.server import default_checkers, serve

    checkers = default_checkers()
    checkers.check["assignment"] = _check_assignment_text
    checkers.schema["assignment"] = assignment_schema
    if sys.stdin.isatty():  # a person, not an editor: say what this is and how to leave
        sys.stderr.write("labsim lsp speaks the Language Server Protocol on standard input and output; an editor "
                         "starts it (docs/editors.md). Ctrl-C ends it.\n")
    serve(checkers)
    return EXIT_OK


def _check_assignment_text(path: str, text: str) -> list[Diagnostic]:
    """What ``labsim grade`` says of an assignment file holding ``text`` (read_assignment, on the
    editor's unsaved text)."""
    from labsim.foundation.diagnostics import Report
    from labsim.foundation.source import loads
    from labsim.runtime.grade.assignment import _AssignmentReader

    try:
        doc = loads(text, path)
    except LabsimError as e:
        return list(e.diagnostics)
    report = Report()
    _AssignmentReader(doc, report).read()
    return sorted(report.diagnostics, key=lambda d: (d.path, d.line, d.col))  # as read_assignment raises them


def cmd_view(args: argparse.Namespace) -> int:
    """Serve the page of a live run or a replayed trace until Ctrl-C; see docs/view.md."""
    from labsim.runtime.view import view

    if args.trace:
        check_output(args.trace, [Path(args.file)], "--trace")
    # --host and --port are the page's; CoppeliaSim's address has options of its own here
    options: dict[str, object] = {k: v for k, v in (("host", args.sim_host), ("port", args.sim_port),
                                                    ("timeout_s", args.sim_timeout)) if v is not None}
    if options and args.backend != "coppeliasim":
        flags = ", ".join("--sim-" + k.removesuffix("_s") for k in options)
        raise LabsimError([Diagnostic(flags, f"only --backend coppeliasim takes {flags}")])
    if args.sim_timeout is not None and not args.sim_timeout > 0:
        raise LabsimError([Diagnostic("--sim-timeout", "give a positive number of seconds")])
    return view(args.file, overrides=parse_overrides(args.set), seed=args.seed, backend=args.backend,
                backend_options=options, host=args.host, port=args.port, trace=args.trace,
                open_browser=not args.no_browser, warn=print_warning, report=print_diagnostics,
                budgets=budgets(args), breaks=args.breaks, read_only=args.read_only,
                token=not args.no_token)


def cmd_sweep(args: argparse.Namespace) -> int:
    """Run a grid of runs and compare the settings; runtime/sweep/driver.py."""
    from labsim.runtime.sweep.driver import run_sweep, sweep_options

    return run_sweep(sweep_options(args))


def cmd_grade(args: argparse.Namespace) -> int:
    """Grade a class against an assignment; runtime/grade/driver.py. The feedback pages' maps are
    drawn by the pictures' renderer, handed over here: applications do not import each other."""
    from labsim.runtime.grade.driver import run_grade
    from labsim.runtime.pictures.feedback import feedback_pictures

    return run_grade(args, pictures=feedback_pictures)


def cmd_serve(args: argparse.Namespace) -> int:
    """Serve CoppeliaSim's ZMQ remote API until Ctrl-C; see docs/coppeliasim.md."""
    from labsim.backends.protocol import RobotRequest
    from labsim.runtime.serve.server import Server, serve

    requests: list[RobotRequest] | None = None
    world = None
    dt = args.dt
    if args.behaviour is not None:
        from labsim.runtime.run import compile_behaviour

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

    log = None if args.quiet else print_warning
    # the fleet script unless asked not to: a tick in 3 or 4 round trips (docs/coppeliasim.md)
    serve(world, robots, args.port, args.host, dt_s=dt, log=log, ready=ready, empty=args.empty,
          fleet_script=not args.per_object)
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

def cmd_scene(args: argparse.Namespace) -> int:
    """Build a behaviour's scene in a running CoppeliaSim; runtime/builder/command.py."""
    from labsim.runtime.builder.command import run_scene

    return run_scene(args)
