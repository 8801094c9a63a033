"""A behaviour file in, a sealed ``Program`` out: the language's pipeline, end to end.

One stage per module: ``labsim.foundation.source.load`` (YAML with positions) ->
``labsim.dsl.syntax.read`` (the file's sections, rule strings parsed by ``labsim.dsl.syntax.parse`` into
``labsim.dsl.syntax.ast``) -> ``labsim.dsl.analysis.check`` (names, arity, types) -> ``labsim.dsl.analysis.lint``
and ``labsim.dsl.analysis.unbounded`` (warnings, on a file without errors) -> ``labsim.dsl.emit.codegen``
(Python source, compiled once) -> ``labsim.dsl.emit.program.Program``, which the runtime binds to
each robot; the generated code calls ``labsim.dsl.library.support`` as it runs. Every stage adds its
problems to one ``Report``, so a file's errors are all raised together, as a LabsimError.
Only placing the robots depends on the seed: ``prepare`` does the rest once, and
``Prepared.program(seed)`` gives each seed's Program (a grader runs a file on several seeds).

This module also turns what the checker knows into the Program's plain fields: nothing of the
YAML file reaches the runtime except what is prepared here.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from types import MappingProxyType

from labsim.dsl.analysis.budget import check_budgets
from labsim.dsl.analysis.check import Checked, check
from labsim.dsl.analysis.crowd import check_crowd
from labsim.dsl.analysis.image_memory import lifetimes, peak_bytes
from labsim.dsl.analysis.lint import lint
from labsim.dsl.analysis.messages import heard_slot
from labsim.dsl.analysis.peers import POSE
from labsim.dsl.analysis.placement import Start, place
from labsim.dsl.analysis.stop import check_stop
from labsim.dsl.analysis.unbounded import check_unbounded
from labsim.dsl.emit.codegen import Generated, generate
from labsim.dsl.emit.program import FunctionText, GroupSignal, Program, RobotGroup, RuleLabel, TimelineEvent
from labsim.dsl.library.builtins import Type
from labsim.dsl.library.support import STATE
from labsim.dsl.syntax.read import FunctionDecl, RobotDecl, read
from labsim.foundation.diagnostics import Diagnostic, LabsimError, Report
from labsim.foundation.limits import DEFAULT_BUDGETS, Budgets
from labsim.foundation.numbers import WHOLE_LIMIT
from labsim.foundation.source import load, loads


def compile_file(path: str | Path, overrides: dict[str, str] | None = None, seed: int | None = None,
                 strict: bool = False, budgets: Budgets = DEFAULT_BUDGETS, text: str | None = None) -> Program:
    """Load, read, check and compile a behaviour file; LabsimError lists every problem.

    ``text``, when given, is compiled as the file at ``path`` would be (its world found from
    there): a live view's edit, not yet saved.
    ``overrides`` set parameters (``--set front=1.0``); ``seed`` replaces the file's ``seed:``.
    The linter's warnings go on the Program; ``strict`` raises them as errors instead.
    ``budgets`` bound its robots, cameras and world (``labsim.dsl.analysis.budget``).
    """
    _check_seed(seed)
    return prepare(path, overrides, strict, budgets, text).program(seed)


def prepare(path: str | Path, overrides: dict[str, str] | None = None, strict: bool = False,
            budgets: Budgets = DEFAULT_BUDGETS, text: str | None = None) -> Prepared:
    """The part of ``compile_file`` no seed changes (the file loaded, read and checked): a file
    compiled for several seeds, as a grader's runs are, is read, checked and generated once,
    and only its robots are placed again for each seed (``Prepared.program``). A file with
    errors raises LabsimError here, as ``compile_file`` does."""
    doc = load(path) if text is None else loads(text, str(path))
    report = Report()
    bf = read(doc, report)
    checked = check(bf, report, overrides)
    if not report.errors:
        check_budgets(checked, budgets, report)
    report.raise_if_errors()
    return Prepared(checked, tuple(report.diagnostics), strict, code_filename(bf.path, overrides))


@dataclass
class Prepared:
    """A checked file, ready to be compiled for any seed (see ``prepare``)."""

    checked: Checked
    diagnostics: tuple[Diagnostic, ...]  # what reading and checking it found (no errors)
    strict: bool
    filename: str  # the generated code's, for tracebacks (``code_filename``)
    _generated: Generated | None = None  # generated once, for the first seed that compiles

    def program(self, seed: int | None = None) -> Program:
        """The Program for ``seed`` (None: the file's own ``seed:``), exactly as ``compile_file``
        gives it; LabsimError for the errors of this seed (a robot that finds no place) and the
        rest that come after placing (the stop condition, crowding, ``strict``'s warnings)."""
        _check_seed(seed)
        checked = self.checked
        report = Report(list(self.diagnostics))
        seed = checked.file.seed if seed is None else seed
        starts, unplaced = place(checked, seed)
        if unplaced is not None:
            report.add(unplaced)
        check_stop(checked, report)
        check_crowd(checked, starts, report)
        report.raise_if_errors()
        lint(checked, report)
        check_unbounded(checked, report)
        if self.strict:
            report.diagnostics = [replace(d, severity="error", notes=(*d.notes, "a warning, made an error by --strict"))
                                  if d.severity == "warning" else d for d in report.diagnostics]
            report.raise_if_errors()
        if self._generated is None:
            self._generated = generate(checked, self.filename)
        warnings = tuple(sorted((d for d in report.diagnostics if d.severity == "warning"),
                                key=lambda d: (d.line, d.col)))
        return _program(checked, self._generated, warnings, seed, starts)


def file_seed(path: str | Path) -> int:
    """The seed a file says (``seed:``, 0 when it says none), read without checking the rest: what a
    sweep runs a file with that does not compile under its first setting (``labsim.runtime.sweep``)."""
    try:
        return read(load(path), Report()).seed
    except LabsimError:  # not YAML, or not readable: nothing of it runs, and no seed is said
        return 0


def _check_seed(seed: int | None) -> None:
    if seed is not None and not (isinstance(seed, int) and 0 <= seed <= WHOLE_LIMIT):
        raise LabsimError([Diagnostic("seed", f"the seed is a whole number from 0 to {WHOLE_LIMIT} (2**53), "
                                              f"not {str(seed)[:40]}")])


def code_filename(path: str, overrides: dict[str, str] | None = None) -> str:
    """The name tracebacks give the generated code: ``<labsim behaviours/wall_follow.yaml>``.

    Overrides are part of it, since they change the code (parameters are folded in).
    """
    return f"<labsim {path}{''.join(f' --set {k}={v}' for k, v in (overrides or {}).items())}>"


def _program(c: Checked, generated: Generated, warnings: tuple[Diagnostic, ...], seed: int,
             starts: tuple[Start, ...]) -> Program:
    bf = c.file
    world = c.world
    assert world is not None  # the checker reports a missing world as an error
    layout = generated.layout
    return Program(
        name=bf.name, path=bf.path, sha256=bf.sha256, dt_s=bf.dt_s, seed=seed, world=world,
        params=MappingProxyType(dict(c.params)), overridden=tuple(c.overridden), warnings=warnings,
        robots=tuple(_group(c, d) for d in bf.robots),
        models=MappingProxyType(dict(c.models)), mechanism_agent=c.mechanism_agent,
        starts=starts,
        channels=c.channels, channel_kinds=MappingProxyType(dict(c.channel_kinds)),
        let_names=tuple(name for name, _ in c.lets), signal_types=MappingProxyType(dict(c.let_types)),
        state_names=tuple(c.states), rules=_rule_labels(c),
        metric_names=tuple(m.name for m in c.metrics), metric_aggregates=tuple(m.aggregate for m in c.metrics),
        metric_better=tuple(m.better for m in c.metrics),
        stop_horizon_s=generated.stop_horizon_s,
        slider_names=tuple(sl.name for sl in c.sliders),
        slider_ranges=MappingProxyType({sl.name: (sl.lo, sl.hi) for sl in c.sliders}),
        slider_start=MappingProxyType({sl.name: sl.value for sl in c.sliders}),
        labels=layout.labels, timeline=_timeline(c),
        slot_of=layout.slot_of, slot_count=layout.slot_count, targets=layout.targets, code=generated.code,
        logs=generated.logs, stop_text=" ".join(c.file.stop.text.value.split()) if c.file.stop else "",
        stop_parts=generated.stop_parts, fold_stop=bf.version != 1, version=bf.version, texts=generated.texts,
        when_rules=generated.when_rules, image_bytes_all=peak_bytes(c, lifetimes(c)).all_bytes,
        shared_labels=layout.shared_labels,
        group_signals=tuple(GroupSignal(name, c.group_sizes[name], layout.members[name], parsed.text.value)
                            for name, parsed in c.lets if name in layout.members),
        functions=tuple(_function_text(d) for d in c.functions.values()),
        lists=MappingProxyType(dict(c.lists)),
        peer_fields=c.peer_fields,
        peer_slots=tuple(STATE if f == "state" else layout.slot_of[f] for f in c.peer_fields),
        received=tuple((r.name, Type.STATE if r.attr == "state" else Type.NUMBER if r.attr in POSE
                        else c.let_types.get(r.attr, Type.NUMBER)) for r in c.received)
        + tuple((heard_slot(h), Type.NUMBER) for h in c.heard),
        said=c.said)


def _function_text(d: FunctionDecl) -> FunctionText:
    line, col = d.body.text.doc.position(d.body.text.index(0))
    return FunctionText(d.name, d.params, d.body.text.value, line, col, d.body.text.doc.source_line(line))


def _group(c: Checked, d: RobotDecl) -> RobotGroup:
    """A group as the runtime needs it; its noise once, or per member when its own parameters differ."""
    members = c.noise.get(d.name, ())
    shared = len(set(members)) <= 1
    return RobotGroup(d.name, c.models[d.name], d.count, d.at, d.paths, c.robot_params.get(d.name, ()),
                      members[0] if members and shared else None, () if shared else members)


def _rule_labels(c: Checked) -> tuple[RuleLabel, ...]:
    return tuple(RuleLabel(r.state, r.number, r.text.value.strip().replace("\n", " "), r.text.node.start_mark.line + 1)
                 for rules in c.states.values() for r in rules)


def _timeline(c: Checked) -> tuple[TimelineEvent, ...]:
    return tuple((event.time_s, tuple((name, value) for name, value, _ in event.settings))
                 for event in c.file.timeline)
