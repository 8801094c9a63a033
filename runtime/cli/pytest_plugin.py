"""Golden traces as pytest tests: the plugin pytest loads through labsim's ``pytest11`` entry point.

It sits beside ``labsim test`` at the end of the pipeline and reuses its comparison
(``labsim.runtime.golden.check_golden``), so a failing item shows the same first-difference
text. ``pytest behaviours/`` collects every behaviour file of the folder named, as ``labsim
test behaviours/`` does, as one item named after the file, and one without a golden trace beside
it fails as ``labsim test`` fails it (so does a behaviour file named on the command line);
deeper folders, which ``labsim test`` does not look in, give the behaviour files that have a
golden only. ``pytest --update-goldens`` records the
goldens instead of comparing. A behaviour file or golden found in a folder that is a link
out of it is a collection error, as ``labsim test`` refuses it (docs/security.md). Items are
independent, so ``pytest -n auto`` (pytest-xdist) runs them in parallel.
"""
from __future__ import annotations

import os
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pytest

# labsim's own modules are imported where they are used, once _no_rewrite has run: imported
# here, with this module, pytest would rewrite their asserts too (without a bytecode cache, parsed
# and compiled anew by pytest in every session that has labsim installed)

if TYPE_CHECKING:
    from _pytest._code.code import TracebackStyle  # what pytest's own repr_failure takes


def pytest_addoption(parser: pytest.Parser, pluginmanager: pytest.PytestPluginManager) -> None:
    _no_rewrite(pluginmanager)
    group = parser.getgroup("labsim", "labsim golden traces")
    group.addoption("--update-goldens", action="store_true", default=False,
                    help="record the golden traces of the behaviour files collected, instead of comparing "
                         "(as labsim test --update-goldens does)")


def _no_rewrite(pluginmanager: pytest.PytestPluginManager) -> None:
    """Keep pytest from rewriting the asserts of labsim's own modules. pytest marks the whole
    package of a plugin it loads by entry point for rewriting, so every labsim module a run
    imports was parsed and compiled anew by pytest (with no bytecode cache, a third of ``pytest
    behaviours/``'s CPU); labsim's asserts are its own checks, not a test's, and need no
    rewritten message. Only this module and its few imports above are rewritten, the run's
    modules (imported by ``runtest``) are not. pytest has no public call for this: without the
    attribute it is left as it is."""
    hook = getattr(pluginmanager, "rewrite_hook", None)
    marked = getattr(hook, "_must_rewrite", None)
    cache = getattr(hook, "_marked_for_rewrite_cache", None)
    if isinstance(marked, set) and "labsim" in marked:
        marked.discard("labsim")
        if isinstance(cache, dict):
            cache.clear()


@pytest.hookimpl(tryfirst=True)
def pytest_sessionfinish(session: pytest.Session) -> None:
    _skip_idle_hypothesis(session.config)


def _skip_idle_hypothesis(config: pytest.Config) -> None:
    """Leave out the hypothesis plugin's end-of-session summary when hypothesis never ran. Its
    summary imports hypothesis whatever the session held, and pytest rewrites the asserts of
    every hypothesis module it imports (a plugin's whole distribution is marked): without a
    bytecode cache about 1.3 s of CPU, most of ``pytest behaviours/``'s start and collection. The
    summary can only say something when hypothesis was imported (a test used it, here or in an
    xdist worker whose reports carry its keys) or one of its options was given: then it stays.
    The plugin's names are read from it, so another version that lacks them is left alone."""
    plugin = config.pluginmanager.get_plugin("hypothesispytest")
    any_option = getattr(plugin, "_any_hypothesis_option", None)
    keys = [getattr(plugin, "STATS_KEY", None), getattr(plugin, "FAILING_EXAMPLES_KEY", None)]
    if plugin is None or "hypothesis" in sys.modules or not callable(any_option) or None in keys:
        return
    reporter = config.pluginmanager.get_plugin("terminalreporter")
    reports = [r for rs in getattr(reporter, "stats", {}).values() for r in rs]
    if any_option(config) or any(k in getattr(r, "__dict__", {}) for r in reports for k in keys):
        return
    config.pluginmanager.unregister(plugin)


def pytest_collect_file(file_path: Path, parent: pytest.Collector) -> BehaviourFile | None:
    from labsim.foundation.kinds import YAML_SUFFIXES, file_kind, golden_path

    if file_path.suffix not in YAML_SUFFIXES:
        return None
    named = _named(file_path, parent.config)
    if not golden_path(file_path).exists() and not named and not _named(file_path.parent, parent.config):
        return None
    # a file found in a folder is that folder's, as for labsim test: a link out of it is not
    # followed, not even to see what kind of file it is (docs/security.md)
    refused = "" if named else links_out(file_path)
    if refused:
        return BehaviourFile.from_parent(parent, path=file_path, refused=refused)
    if file_kind(file_path) != "behaviour":  # world files and other YAML are not collected
        return None
    return BehaviourFile.from_parent(parent, path=file_path)


def links_out(path: Path) -> str:
    """Why a behaviour file found in a folder, or the golden beside it, may not be read there
    (a symbolic link that leads out of the folder, ``policy_problem``), or ''."""
    from labsim.foundation.files import ALLOW_ENV, policy_problem
    from labsim.foundation.kinds import golden_path

    for f in (path, golden_path(path)):
        refused = os.path.lexists(f) and policy_problem(f.name, f.parent)
        if refused:
            return (f"{f}: {refused}; pytest reads files found in a folder only inside it, as labsim "
                    f"test does (or in a folder {ALLOW_ENV} allows)")
    return ""


def _named(path: Path, config: pytest.Config) -> bool:
    """Whether the file (or folder) was given on the command line itself (not found in a folder
    given); pytest without arguments names its ``testpaths``, or the folder it starts in."""
    for arg in config.args:
        candidate = Path(arg.split("::", 1)[0])
        if not candidate.is_absolute():
            candidate = config.invocation_params.dir / candidate
        if candidate.resolve() == path.resolve():
            return True
    return False


class GoldenMismatch(Exception):
    """A behaviour's run differs from its golden trace (or has none): the text labsim test prints."""


class BehaviourFile(pytest.File):
    def __init__(self, *args: Any, refused: str = "", **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.refused = refused  # why the file may not be read (a link out of its folder), or ''

    def collect(self) -> Iterator[GoldenItem]:
        if self.refused:  # a collection error: pytest shows the message alone and exits with 2
            raise self.CollectError(self.refused)
        yield GoldenItem.from_parent(self, name=self.path.stem)


class GoldenItem(pytest.Item):
    """One behaviour file re-run on the default backend and compared with its golden."""

    def runtest(self) -> None:
        from labsim.runtime.golden import check_golden, record_golden  # the run's modules: after _no_rewrite

        if self.config.getoption("update_goldens"):
            golden, summary = record_golden(self.path)
            self.user_properties.append(("golden", str(golden)))
            self.add_report_section("call", "labsim", f"recorded {golden} ({summary.ticks} ticks)")
            return
        shown = self._shown_path()
        verdict = check_golden(self.path, record_with=f"pytest {shown} --update-goldens", shown_as=shown)
        if not verdict.passed:
            raise GoldenMismatch(str(verdict))

    def _shown_path(self) -> Path:
        """The file as the person typed it: relative to where pytest started, when it is under it."""
        try:
            return self.path.relative_to(self.config.invocation_params.dir)
        except ValueError:
            return self.path

    def repr_failure(self, excinfo: pytest.ExceptionInfo[BaseException],
                     style: TracebackStyle | None = None) -> str:
        if isinstance(excinfo.value, GoldenMismatch):
            return str(excinfo.value)
        from labsim.foundation.diagnostics import LabsimError

        if isinstance(excinfo.value, LabsimError):
            return "\n".join([f"FAIL {self.path}: it does not compile"]
                             + [d.format() for d in excinfo.value.diagnostics])
        return str(super().repr_failure(excinfo, style=style))

    def reportinfo(self) -> tuple[Path, int, str]:
        return self.path, 0, f"golden trace of {self.path.name}"
