"""The ``labsim`` command line: run, check, test, plot, worlds.

Exit codes: 0 success; 1 a golden trace differs (or is missing); 2 a user's mistake (a bad
behaviour file, an unknown option or parameter, an unreachable simulator), reported as
``path:line:col: message`` without a Python traceback; 130 interrupted with Ctrl-C (the
trace so far is kept).
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path
from typing import Sequence

from labsim import __version__
from labsim.backends import DEFAULT, REGISTRY, load_backend
from labsim.backends.protocol import BackendError
from labsim.backends.world import builtin_worlds
from labsim.dsl.errors import Diagnostic, LabsimError
from labsim.runtime.golden import compare, golden_path
from labsim.runtime.report import ProgressBar, format_summary
from labsim.runtime.run import Run, compile_behaviour, stop_horizon
from labsim.runtime.trace import TraceFormatError, read_trace

EXIT_OK, EXIT_FAILED, EXIT_USAGE, EXIT_INTERRUPTED = 0, 1, 2, 130


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # type: ignore[override]
        self.print_usage(sys.stderr)
        sys.stderr.write(f"labsim: error: {message}\n")
        raise SystemExit(EXIT_USAGE)


def _parser() -> argparse.ArgumentParser:
    p = _Parser(prog="labsim", description="Run robotics labs written as behaviour files.")
    p.add_argument("--version", action="version", version=f"labsim {__version__}")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)

    run = sub.add_parser("run", help="run a behaviour and print a summary")
    run.add_argument("file", help="the behaviour file (.yaml)")
    run.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                     help="override a parameter from the file's 'params:' (repeatable)")
    run.add_argument("--seed", type=int, help="override the file's seed")
    run.add_argument("--trace", metavar="PATH", help="write the trace (CSV) to PATH")
    run.add_argument("--backend", default=DEFAULT, choices=sorted(REGISTRY), help="simulator (default: %(default)s)")
    run.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                     help="show a progress bar (default: when stderr is a terminal)")
    run.add_argument("--quiet", "-q", action="store_true", help="print no summary")

    check = sub.add_parser("check", help="check behaviour files without running them")
    check.add_argument("files", nargs="+")

    test = sub.add_parser("test", help="re-run behaviours and compare them with their golden traces")
    test.add_argument("paths", nargs="*", default=["behaviours"],
                      help="behaviour files or folders (default: behaviours)")
    test.add_argument("--update-goldens", action="store_true", help="record the golden traces anew")

    plot = sub.add_parser("plot", help="draw a trace: the world to scale and every trajectory")
    plot.add_argument("trace")
    plot.add_argument("-o", "--output", required=True, metavar="PNG")

    sub.add_parser("worlds", help="list the built-in worlds")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    try:
        return {"run": cmd_run, "check": cmd_check, "test": cmd_test, "plot": cmd_plot,
                "worlds": cmd_worlds}[args.command](args)
    except LabsimError as e:
        _print_diagnostics(e.diagnostics)
        return EXIT_USAGE
    except BackendError as e:
        sys.stderr.write(f"labsim: error: {e}\n")
        return EXIT_USAGE
    except KeyboardInterrupt:
        sys.stderr.write("labsim: interrupted\n")
        return EXIT_INTERRUPTED


def _print_diagnostics(diagnostics: list[Diagnostic]) -> None:
    for d in diagnostics:
        sys.stderr.write(d.format() + "\n")
    errors = sum(d.severity == "error" for d in diagnostics)
    if errors > 1:
        sys.stderr.write(f"{errors} errors\n")


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
    behaviour = compile_behaviour(args.file, _overrides(args.set))
    if args.seed is not None:
        if args.seed < 0:
            raise LabsimError([Diagnostic("--seed", "the seed is 0 or a positive whole number")])
        behaviour.program.seed = args.seed
    if args.trace:
        _check_writable(args.trace)
    backend = load_backend(args.backend)
    run = behaviour.bind(backend, trace=args.trace, warn=_warn)
    show = args.progress if args.progress is not None else sys.stderr.isatty()
    bar = ProgressBar(stop_horizon(behaviour.program)) if show else None
    try:
        summary = run.run(progress=bar)
    finally:
        if bar is not None:
            bar.clear()
        run.close()
    if not args.quiet:
        print(format_summary(summary, run))
    return EXIT_INTERRUPTED if summary.interrupted else EXIT_OK


def _check_writable(path: str) -> None:
    p = Path(path)
    if p.is_dir():
        raise LabsimError([Diagnostic(f"--trace {path}", "is a folder; give a file name such as run.csv")])
    if not p.parent.exists():
        raise LabsimError([Diagnostic(f"--trace {path}", f"folder '{p.parent}' does not exist")])
    if not os.access(p.parent, os.W_OK) or (p.exists() and not os.access(p, os.W_OK)):
        raise LabsimError([Diagnostic(f"--trace {path}", "cannot write there (permission denied)")])


def cmd_check(args: argparse.Namespace) -> int:
    problems: list[Diagnostic] = []
    for f in args.files:
        try:
            behaviour = compile_behaviour(f)
            problems += behaviour.program.warnings
            print(f"{f}: ok")
        except LabsimError as e:
            problems += e.diagnostics
    if problems:
        _print_diagnostics(problems)
    return EXIT_USAGE if any(d.severity == "error" for d in problems) else EXIT_OK


def _behaviour_files(paths: list[str]) -> list[Path]:
    files: list[Path] = []
    for p in map(Path, paths):
        if p.is_dir():
            files += sorted(f for f in p.glob("*.yaml") if not f.name.endswith("_with_error.yaml"))
        elif p.exists():
            files.append(p)
        else:
            raise LabsimError([Diagnostic(str(p), "no such file or folder")])
    return files


def cmd_test(args: argparse.Namespace) -> int:
    files = _behaviour_files(args.paths)
    if not files:
        raise LabsimError([Diagnostic(" ".join(args.paths), "no behaviour files (*.yaml) here")])
    failed = 0
    for f in files:
        golden = golden_path(f)
        if args.update_goldens:
            fd, tmp = tempfile.mkstemp(suffix=".csv", dir=golden.parent)
            os.close(fd)
            try:
                summary = _record(f, tmp)
                os.chmod(tmp, 0o644)  # mkstemp makes it private; a golden is a shared file
                os.replace(tmp, golden)
            finally:
                if os.path.exists(tmp):
                    os.unlink(tmp)
            print(f"recorded {golden} ({summary.ticks} ticks)")
            continue
        if not golden.exists():
            print(f"FAIL {f}: no golden trace {golden}; record one with: labsim test {f} --update-goldens")
            failed += 1
            continue
        with tempfile.TemporaryDirectory() as d:
            actual = Path(d) / "actual.csv"
            _record(f, actual)
            try:
                expected_trace = read_trace(golden)
            except TraceFormatError as e:
                print(f"FAIL {f}: {e}")
                failed += 1
                continue
            difference = compare(expected_trace, read_trace(actual))
        if difference is None:
            print(f"ok   {f}")
        else:
            failed += 1
            print(f"FAIL {f} (golden {golden})")
            print("\n".join("  " + line for line in str(difference).splitlines()))
    print(f"{len(files) - failed} passed, {failed} failed")
    return EXIT_FAILED if failed else EXIT_OK


def _record(behaviour_path: Path, trace_path: str | Path):  # type: ignore[no-untyped-def]
    behaviour = compile_behaviour(behaviour_path)
    run = behaviour.bind(load_backend(DEFAULT), trace=trace_path, warn=lambda m: None)
    try:
        summary = run.run()
    finally:
        run.close()
    if summary.interrupted:
        raise KeyboardInterrupt
    return summary


def cmd_plot(args: argparse.Namespace) -> int:
    from labsim.runtime.plot import plot_trace

    try:
        out = plot_trace(args.trace, args.output)
    except TraceFormatError as e:
        raise LabsimError([Diagnostic(args.trace, str(e).removeprefix(f"{args.trace}: "))]) from None
    except ValueError as e:
        raise LabsimError([Diagnostic(args.output, str(e))]) from None
    print(f"wrote {out}")
    return EXIT_OK


def cmd_worlds(args: argparse.Namespace) -> int:
    from labsim.dsl.errors import Report
    from labsim.dsl.world import load_world

    for name, path in builtin_worlds().items():
        world = load_world(path, Report())
        print(f"{name:<16} {world.description if world else '(damaged world file)'}")
    return EXIT_OK


if __name__ == "__main__":
    raise SystemExit(main())
