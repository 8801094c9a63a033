"""No text from a user's file reaches ``str.format``, ``%``, ``getattr``, a compiled regular
expression or ``eval``/``exec`` (docs/security.md).

Robot ``paths:`` were given to ``str.format``: ``{i.__class__.__mro__[1]}`` walked Python
attributes and ``{i:>300000000}`` made a 300 MB path. They are templates now
(backends/scene/object_paths.py). This test scans the package's syntax trees for every place a
value could meet one of these sinks and fails on any that is not on ``ALLOWED``, each with
the reason it is safe. Precise rather than complete: a call is flagged by its shape, not by
following where its values come from, so the allow-list stays short and every entry is read.

* ``X.format(...)`` / ``X.format_map(...)`` where X is not a string literal, and the builtin
  ``format(value, spec)`` with a spec that is not a literal;
* ``X % Y`` where X is not a string literal and Y is a tuple, a dict or a string (the shapes of
  printf formatting; ``(i + 1) % n`` is arithmetic and not flagged);
* ``getattr``/``setattr``/``hasattr``/``delattr`` with an attribute name that is not a literal;
* ``re.compile``/``re.match``/... with a pattern that is not a literal;
* ``eval``, ``exec``, ``compile`` and ``string.Template``.
"""
from __future__ import annotations

import ast
from pathlib import Path

import pytest
from helpers import PACKAGE_DIRS, ROOT

# the package: its top-level modules and its three folders (not tests, benchmarks, nor any
# virtual environment or build folder that may sit in the checkout)
RE_FUNCS = {"compile", "match", "fullmatch", "search", "sub", "subn", "split", "findall", "finditer"}
ATTR_FUNCS = {"getattr", "setattr", "hasattr", "delattr"}

DIAGNOSTIC = "Diagnostic.format(), labsim's own method that prints a diagnostic; not str.format"
# (file, the flagged expression as ast.unparse writes it) -> why it is safe
ALLOWED: dict[tuple[str, str], str] = {
    ("runtime/grade/measure.py",
     "re.compile(\"^metric '([A-Za-z_][A-Za-z0-9_]*)\" + re.escape(MEASURED_SUFFIX) + \"'\")"):
        "a pattern made once from the module's constant suffix, escaped; no user text",
    ("runtime/api.py", "getattr(importlib.import_module(module), name)"):
        "PICTURES, the module's own constant module:name of the notebook's renderer, not user text",
    ("runtime/lsp/server.py", "super().format(record)"):
        "logging.Formatter.format of a log record: the handler's fixed format string, not an editor's text",
    ("runtime/interrupts.py", "getattr(signal, name, None)"):
        "names from StopSignals.SIGNALS, a constant tuple (SIGHUP is missing on Windows)",
    ("runtime/view/session.py", "getattr(self, method, None)"):
        "method names from MESSAGES, a constant table; a page's type only picks an entry it has",
    ("__init__.py", "getattr(api, name)"):
        "module __getattr__: name is an attribute Python looks up on labsim, checked against __all__",
    ("backends/__init__.py", "getattr(importlib.import_module(module_name), attribute)"):
        "the backend registry's own entries (module:attribute), not user text",
    ("runtime/serve/mechanism_edit.py", "getattr(self, '_' + name.removeprefix('sim.'))"):
        "names from MECHANISM_CALLS, a constant tuple, never from a request",
    ("runtime/serve/mechanism_edit.py", "getattr(self, '_own_' + name.removeprefix('sim.'))"):
        "names from WRAPPED, a constant tuple, never from a request",
    ("runtime/serve/script_host.py", "getattr(self, '_' + name.removeprefix('sim.'))"):
        "names from SCRIPT_CALLS, a constant tuple, never from a request",
    ("runtime/serve/script_host.py", "getattr(self, '_own_' + name.removeprefix('sim.'))"):
        "names from the three literals of wrap(), never from a request",
    ("runtime/serve/scene_edit.py", "getattr(self, '_' + name.removeprefix('sim.'))"):
        "names from the module's fixed table of functions, never from a request",
    ("runtime/serve/sim_objects.py", "getattr(self, '_' + name.removeprefix('sim.'))"):
        "names from OBJECT_CALLS, a constant tuple, never from a request",
    ("runtime/serve/sim_session.py", "getattr(self, '_' + name.removeprefix('sim.'))"):
        "names from SESSION_CALLS, a constant tuple, never from a request",
    ("runtime/serve/sim_signals.py", "getattr(self, '_' + name.removeprefix('sim.'))"):
        "names from SIGNAL_CALLS, a constant tuple, never from a request",
    ("runtime/serve/sim_api.py", "getattr(self, '_sim_' + name.removeprefix('sim.'))"):
        "names from FUNCTIONS, a constant tuple; a request's func is looked up in the dict built here",
    ("runtime/serve/sim_api.py", "getattr(motor, mode, True)"):
        "mode is one of two literals chosen by the handler",
    ("runtime/observers.py", "exec(compile(source, '<labsim trace row>', 'exec'), space)"):
        "a trace row's format, written from column indices and fixed names only; texts are arguments",
    ("runtime/observers.py", "compile(source, '<labsim trace row>', 'exec')"):
        "see the exec above",
    ("runtime/view/record.py", "exec(compile(source, '<labsim view tick>', 'exec'), space)"):
        "a live view's tick hook, written from column indices and fixed names only",
    ("runtime/view/record.py", "compile(source, '<labsim view tick>', 'exec')"):
        "see the exec above",
    ("backends/pymunk/fleet_sense.py", "exec(compile('\\n'.join(lines), '<labsim pymunk sense>', 'exec'), env)"):
        "code generated from the models' channel tables, no user text",
    ("backends/pymunk/fleet_sense.py", "compile('\\n'.join(lines), '<labsim pymunk sense>', 'exec')"):
        "see the exec above",
    ("dsl/analysis/image_memory.py", "getattr(item, f.name)"):
        "f is a field of one of labsim's own AST or declaration dataclasses (dataclasses.fields), never user text",
    ("dsl/library/builtins.py", "getattr(importlib.import_module(module), name)"):
        "the builtin table's own module:name entries",
    ("dsl/library/support.py", "format(value, spec)"):
        "a label's or log's format spec, which dsl/syntax/parse.py admits only as _FORMAT_SPEC (width and "
        "precision at most two digits) or the printf form's _PRINTF",
    ("dsl/syntax/parse.py", "getattr(e, f.name)"):
        "dataclass fields of the language's own AST nodes",
    ("dsl/analysis/functions.py", "getattr(e, name)"):
        "dataclass fields of the language's own AST nodes (a function body's copy, ast.child_fields)",
    ("dsl/syntax/ast.py", "getattr(e, name)"):
        "the fields of the language's own AST node classes that hold sub-expressions (child_fields)",
    ("dsl/syntax/ast.py", "getattr(self, method)"):
        "a visitor's method for one of the language's own node classes: 'visit_' and the class's name",
    ("dsl/syntax/ast.py", "hasattr(cls, f'visit_{n.__name__}')"):
        "the name of one of the language's own node classes",
    ("dsl/syntax/ast.py", "hasattr(self, name)"):
        "'visit_' and the name of one of the language's own node classes",
    ("dsl/emit/program.py", "exec(code.compiled, scope)"):
        "code compiled by dsl/emit/codegen.py from a checked program; user text enters it only as "
        "repr() literals and checked identifiers",
    ("dsl/emit/codegen.py", "compile(source, filename, 'exec')"):
        "the generated module (see dsl/emit/program.py below)",
    ("foundation/diagnostics.py", "d.format()"): DIAGNOSTIC,
    ("dsl/library/support.py", "head.format()"): DIAGNOSTIC,
    ("runtime/cli/pytest_plugin.py", "d.format()"): DIAGNOSTIC,
    ("runtime/run.py", "d.format()"): DIAGNOSTIC,
    ("runtime/view/edits.py", "d.format()"): DIAGNOSTIC,
    ("runtime/grade/pages.py", "d.format()"): DIAGNOSTIC,
    ("runtime/grade/runs.py", "first.format()"): DIAGNOSTIC,
    ("runtime/sweep/grid.py", "errors[0].format()"): DIAGNOSTIC,
    ("runtime/view/live.py", "d.format()"): DIAGNOSTIC,
}


def _literal_str(node: ast.AST) -> bool:
    return isinstance(node, ast.Constant) and isinstance(node.value, str)


def _called(node: ast.Call) -> str:
    f = node.func
    if isinstance(f, ast.Name):
        return f.id
    if isinstance(f, ast.Attribute):
        base = f.value.id if isinstance(f.value, ast.Name) else ""
        return f"{base}.{f.attr}" if base else "." + f.attr
    return ""


def _is_sink(node: ast.AST) -> bool:
    """Whether ``node`` is one of the shapes of the module docstring."""
    if isinstance(node, ast.BinOp):
        return (isinstance(node.op, ast.Mod) and not _literal_str(node.left)
                and (isinstance(node.right, (ast.Tuple, ast.Dict, ast.JoinedStr)) or _literal_str(node.right)))
    if not isinstance(node, ast.Call):
        return False
    name, f, args = _called(node), node.func, node.args
    if isinstance(f, ast.Attribute) and f.attr in ("format", "format_map"):
        return not _literal_str(f.value)
    if name in ATTR_FUNCS or name == "format":
        return len(args) > 1 and not _literal_str(args[1])
    if name.startswith("re.") and name[3:] in RE_FUNCS:
        return bool(args) and not _literal_str(args[0])
    return name in ("eval", "exec", "compile", "string.Template", "Template")


def findings(tree: ast.AST) -> list[str]:
    """The flagged expressions of one module, as ast.unparse writes them."""
    return [ast.unparse(n) for n in ast.walk(tree) if _is_sink(n)]


def _scan() -> set[tuple[str, str]]:
    found = set()
    paths = [*ROOT.glob("*.py"), *(p for d in PACKAGE_DIRS for p in (ROOT / d).rglob("*.py"))]
    for path in sorted(paths):
        rel = path.relative_to(ROOT)
        for expr in findings(ast.parse(path.read_text(encoding="utf-8"), str(rel))):
            found.add((rel.as_posix(), expr))
    return found


@pytest.mark.slow  # seconds: walks the whole package's code; handed out first
def test_no_user_text_reaches_a_format_or_attribute_sink() -> None:
    found = _scan()
    new = sorted(found - ALLOWED.keys())
    assert not new, "a value meets format/%/getattr/regex/exec here; use a literal, a template with " \
                    "fixed placeholders (object_paths.fill), or add it to ALLOWED with the reason:\n" + \
                    "\n".join(f"  {f}: {e}" for f, e in new)
    stale = sorted(ALLOWED.keys() - found)
    assert not stale, f"ALLOWED lists places that are gone: {stale}"


def test_the_scan_flags_each_shape() -> None:
    """The checker itself: each sink shape is caught, arithmetic and literals are not."""
    flagged = findings(ast.parse(
        "paths['robot'].format(i=i)\n"
        "template.format_map(values)\n"
        "text % (a, b)\n"
        "text % {'a': 1}\n"
        "getattr(obj, user_name)\n"
        "re.compile(user_pattern)\n"
        "eval(source)\n"
        "string.Template(text)\n"
        "format(value, user_spec)\n"))
    assert len(flagged) == 9, flagged
    assert findings(ast.parse(
        "'/P[{i}]'.format(i=1)\n"
        "'%d' % n\n"
        "(i + 1) % n\n"
        "x % 1.0\n"
        "getattr(obj, 'name', None)\n"
        "re.compile(r'^[a-z]+$')\n"
        "f'{value!r}'\n"
        "format(value, '.2f')\n")) == []


def test_the_issues_injection_strings_are_refused_by_check(tmp_path: Path) -> None:
    """Each injection of the report is a positioned error of labsim check, not a crash, a
    KeyError, a memory address or a 300 MB path."""
    from labsim.dsl.compile import compile_file
    from labsim.foundation.diagnostics import LabsimError

    injections = {
        "robot": ["/P{x}", "{0}x{1}", "/P{i.__class__.__mro__[1].__subclasses__}", "/P{i:>300000000}",
                  "/P{i!r}", "/P{", "/P{}", "/P%s", "/P$HOME", "/P\\u0000", "/P" + "x" * 300, "/P p"],
        "sonar": ["./s{i}", "./s{k.real}", "./s{k:08}"],
        "left_motor": ["./m{i}", "./m{k}"],
    }
    for key, texts in injections.items():
        for text in texts:
            path = tmp_path / "b.yaml"
            quoted = text.replace("\\", "\\\\").replace('"', '\\"')
            path.write_text(f'labsim: 1\nworld: walls_lab4\nstop: time >= 1\nrobots:\n  r:\n'
                            f'    model: pioneer_p3dx\n    paths:\n      {key}: "{quoted}"\n'
                            f'rules:\n  - always stop()\n')
            try:
                compile_file(path)
            except LabsimError as e:
                message = str(e)
            else:
                raise AssertionError(f"{key}: {text!r} passed labsim check")
            assert "b.yaml:8:" in message and " at 0x" not in message, message
            assert len(message) < 2000, message[:200]


def test_templates_fill_literally_and_check_what_the_models_use() -> None:
    from labsim.backends.coppeliasim import MODEL_PATHS
    from labsim.backends.scene.object_paths import fill, problem

    assert fill("/PioneerP3DX[{i}]", i=3) == "/PioneerP3DX[3]"
    assert fill("./ultrasonicSensor[{k}]/x{0}", k=7) == "./ultrasonicSensor[7]/x{0}"
    assert fill("/P{i.__class__}", i=1) == "/P{i.__class__}"  # no attribute is ever looked up
    assert fill("/P{i:>300000000}", i=1) == "/P{i:>300000000}"
    for model in MODEL_PATHS.values():
        for key, template in model.items():
            if isinstance(template, str):
                assert problem(key, template) is None, (key, template)
    assert problem("robot", "/Robot{2}/base") is None  # CoppeliaSim's own {n}
    assert problem("robot", "/Robot[{i}]") is None and problem("sonar", "./s[{k}]") is None


@pytest.mark.slow
def test_a_timeline_key_of_100000_digits_is_an_error_not_minutes_of_backtracking(tmp_path: Path) -> None:
    """The timeline's 'at TIME' pattern split a run of digits every way it could: 10,000 digits
    and an x took 7 s, 100,000 more than eight minutes. A generous bound, not a measurement.
    (A YAML key over 1024 characters must be written as an explicit '? key'.)"""
    import subprocess
    import sys

    path = tmp_path / "b.yaml"
    path.write_text("labsim: 1\nworld: crane\nstop: time >= 1\nsliders:\n  arm: {min: -1, max: 1}\n"
                    f"bind:\n  Arm_Actuator.velocity: arm\ntimeline:\n  - ? at {'1' * 100_000}x\n    : arm = 1\n")
    out = subprocess.run([sys.executable, "-m", "labsim", "check", str(path)], capture_output=True, text=True,
                         timeout=240)
    assert out.returncode == 2 and "a timeline entry starts with 'at'" in out.stderr, out.stderr[-500:]


def test_the_python_api_refuses_a_bad_template_with_a_backend_error() -> None:
    """Paths that bypass labsim check (CoppeliaSimBackend(paths=...), a RobotRequest built in
    Python) are checked where the backend reads them: a BackendError, no KeyError."""
    import pytest

    from labsim.backends.coppeliasim.fleet import _paths
    from labsim.backends.protocol import BackendError, RobotRequest
    from labsim.backends.scene.models import PIONEER_P3DX
    from labsim.backends.scene.world import Pose, builtin_worlds
    from labsim.backends.scene.world_file import load_world
    from labsim.foundation.diagnostics import Report

    world = load_world(builtin_worlds()["walls_lab4"], Report())
    ok = RobotRequest("pioneer", PIONEER_P3DX, Pose(0, 0, 0), ("sonar1",))
    assert _paths(world, ok, {"robot": "/MyPioneer[{i}]"})["robot"] == "/MyPioneer[{i}]"
    for overrides in ({"robot": "/P{x}"}, {"sonar": "./s{i.__class__}"}, {"robot": "/P{i:>300000000}"}):
        with pytest.raises(BackendError, match="robot 'pioneer'"):
            _paths(world, ok, overrides)
    bad = RobotRequest("pioneer", PIONEER_P3DX, Pose(0, 0, 0), ("sonar1",), paths=(("robot", "{0}"),))
    with pytest.raises(BackendError, match="starts with '/'"):
        _paths(world, bad, {})
