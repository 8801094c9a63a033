"""The grader's pages: one feedback page per student and the class overview, static HTML.

The last stage of ``labsim grade``, beside the gradebook (runtime/grade/gradebook.py); both read
the same ``Grade`` rows. A feedback page shows the student every diagnostic with its caret, the
criteria with their values against the thresholds (and the reference behaviour's beside them),
each seed's run, the map of seed 1 (drawn by the pictures' renderer, which the command line
hands over), the rules that never fired, and the faults and warnings apart from the log lines.
The overview shows the teacher the status counts, the distribution of the score and of each
metric (SVG histograms, ``histogram.py``), the likely copies, and every student linked to their page. The
pages load nothing from the network (a Content-Security-Policy says so to the browser) and
every piece of text from a file or a run is escaped.
"""
from __future__ import annotations

import html
import math
import re
import shlex
from collections.abc import Iterable
from pathlib import Path

from labsim.dsl.syntax import ast as dsl_ast
from labsim.foundation.diagnostics import Diagnostic, LabsimError
from labsim.foundation.files import read_head, write_output
from labsim.foundation.inert import inert
from labsim.foundation.kinds import YAML_SUFFIXES
from labsim.runtime.grade.assignment import MOVED, Assignment, Criterion
from labsim.runtime.grade.contract import HOSTILE, STATUSES
from labsim.runtime.grade.gradebook import messages, page_names
from labsim.runtime.grade.histogram import histogram_svg
from labsim.runtime.grade.score import Grade, Graded, first_fault

CSP = "default-src 'none'; img-src 'self'; style-src 'unsafe-inline'"
STYLE = """body{font-family:system-ui,sans-serif;margin:2em auto;max-width:60em;color:#222;padding:0 1em}
table{border-collapse:collapse;margin:.5em 0 1.5em}td,th{border:1px solid #ccc;padding:.25em .6em;text-align:left}
th{background:#f3f3f3}.pass{color:#176317;font-weight:600}.fail{color:#a31515;font-weight:600}
pre{background:#f7f7f7;border:1px solid #ddd;padding:.6em;overflow-x:auto}.muted{color:#777}
.status{display:inline-block;padding:.1em .6em;border-radius:1em;background:#eee}
.charts img{width:32%;min-width:18em;margin:.2em}"""


def e(text: object) -> str:
    """Text for a page: control characters made visible (line breaks kept), then HTML-escaped (quotes too)."""
    return html.escape("\n".join(inert(line) for line in str(text).split("\n")), quote=True)


# how every page the grader writes begins: what tells its pages from anyone else's files in --out
PAGE_HEAD = ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
             f"<meta http-equiv=\"Content-Security-Policy\" content=\"{CSP}\">")


def _page(title: str, body: list[str]) -> str:
    return (PAGE_HEAD +
            f"<title>{e(title)}</title><style>{STYLE}</style></head><body>\n" + "\n".join(body) + "\n</body></html>\n")


def _number(value: float | None) -> str:
    if value is None:
        return ""
    return "no value" if math.isnan(value) else f"{value:.4g}"  # an inf as such


def _table(header: Iterable[str], rows: Iterable[Iterable[str]]) -> str:
    """A table of cells already escaped (the callers escape what they put in)."""
    head = "".join(f"<th>{h}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td>{c}</td>" for c in row) + "</tr>" for row in rows)
    return f"<table><tr>{head}</tr>{body}</table>"


_WORDS = {"count": "how many times the condition became true",
          "duration": "the seconds during which the condition held",
          "minimum": "the least value of the expression over the run",
          "maximum": "the greatest value of the expression over the run",
          "mean": "the mean of the expression over the run",
          "rms": "the root mean square of the expression over the run",
          "final": "the value of the expression at the end of the run"}
_METRES = re.compile(r"^(sonar|prox)\d+$|^[xy]$")


def metric_words(assignment: Assignment, metric: str) -> tuple[str, str, str]:
    """A measured metric in words, its formula as the assignment writes it, and its unit."""
    decl = next((m for m in assignment.measure if m.name == metric), None)
    if decl is None or not isinstance(decl.value.node, dsl_ast.Call):
        return "", "", ""
    call = decl.value.node
    names = {n.id for n in _names(call)}
    unit = ("s" if call.func == "duration" or (call.func != "count" and names == {"time"}) else
            "" if call.func == "count" else
            "m" if names and all(_METRES.match(n) for n in names) else
            "m/s" if names == {"forward_speed"} else "")
    return _WORDS.get(call.func, call.func), assignment.definition(metric), unit


def _names(node: object) -> list[dsl_ast.Name]:
    if isinstance(node, dsl_ast.Name):
        return [node]
    out: list[dsl_ast.Name] = []
    for value in vars(node).values() if hasattr(node, "__dict__") else ():
        for item in value if isinstance(value, tuple) else (value,):
            if isinstance(item, dsl_ast.Expr):
                out += _names(item)
    return out


def _needed(c: Criterion) -> str:
    if c.builtin:
        return f"at least {c.at_least:g} m" if c.name == MOVED else "yes"
    if c.worst is not None:
        return f"0 points at {c.worst:g}, full at {c.best:g}"
    return f"at least {c.at_least:g}" if c.at_least is not None else f"at most {c.at_most:g}"


def run_command(g: Grade, assignment: Assignment, seed: int) -> str:
    """The ``labsim run`` command that makes a seed's run again, with the grader's params."""
    sets = " ".join(f"--set {shlex.quote(f'{k}={v}')}" for k, v in sorted(assignment.params.items()))
    name = Path(g.path).name
    name = f"./{name}" if name.startswith("-") else name  # never read as an option
    return " ".join(p for p in ("labsim run", shlex.quote(name), sets, f"--seed {seed}") if p)


def _with_unit(value: float | None, unit: str) -> str:
    return "" if value is None else e(_number(value) + (f" {unit}" if unit and not math.isnan(value) else ""))


def _criteria_rows(g: Grade, assignment: Assignment, reference: Grade | None) -> list[list[str]]:
    ref = {r.name: r for r in reference.criteria} if reference is not None else {}
    by_name = {c.name: c for c in assignment.criteria}
    rows = []
    for r in g.criteria:
        c = by_name[r.name]
        if r.source == "built-in":
            words, formula, unit = r.description, "", "m" if r.name == MOVED else ""
        elif r.source == "student":
            words, formula, unit = "a metric you defined in your file (from: student)", "", ""
        else:
            words, formula, unit = metric_words(assignment, r.name)
            words += " (mean over the seeds)"
        definition = e(words) + (f"<br><code>{e(formula)}</code>" if formula else "")
        value = _with_unit(r.value, unit)
        shown = _with_unit(ref[r.name].value, unit) if r.name in ref else ""
        verdict = f"<span class=\"{'pass' if r.passed else 'fail'}\">{'pass' if r.passed else 'fail'}</span>"
        if r.required:
            verdict += " <strong>(required)</strong>"
        if r.why:
            verdict += f"<br><small>{e(r.why)}</small>"
        rows.append([f"<strong>{e(r.name)}</strong>", definition, value, shown, e(_needed(c) + (f" {unit}" if unit
                     and c.name != MOVED and c.worst is None else "")), e(f"{r.points:.3g} / {r.weight:g}"), verdict])
    return rows


def feedback_page(g: Grade, assignment: Assignment, pictures: tuple[str, str | None] | None,
                  reference: Grade | None) -> str:
    """One student's page; see the module docstring."""
    title = assignment.title
    score = f"{g.score:g} / 100" if g.score is not None else "not graded"
    body = [f"<h1>{e(title)}: {e(g.student)}</h1>",
            f"<p><span class=\"status\">{e(g.status)}</span> <strong>{e(score)}</strong></p>"]
    if g.gate:
        why = next((r.why for r in g.criteria if r.name == g.gate), "")
        body.append(f"<p class=\"fail\">The required criterion {e(g.gate)} failed, so the score is the "
                    f"assignment's {assignment.gate_score:g} for a failed gate (or what the other criteria earned, "
                    f"if that is less). Why: {e(why)}</p>")
    elif g.reason:
        body.append(f"<p>{e(g.reason)}</p>")
    errors = [d for d in g.diagnostics if d.severity == "error"]
    warnings = [d for d in g.diagnostics if d.severity != "error"]
    if errors:
        shown = "\n".join(d.format() for d in errors)
        body += ["<h2>Errors in the file</h2>", f"<pre class=\"diagnostics\">{e(shown)}</pre>"]
    if g.criteria:
        body += ["<h2>Criteria</h2>", _table(["criterion", "what it measures", "your value", "reference"
                                              if reference is not None else "", "needed", "points", "result"],
                                             _criteria_rows(g, assignment, reference))]
    if pictures:
        map_file, gif_file = pictures
        body += ["<h2>The map of seed " + e(g.runs[0].seed) + "</h2>",
                 "<p class=\"muted\">the path from the ring (start) to the arrow (end); a red cross marks each "
                 "collision</p>",
                 f"<img class=\"map\" src=\"{e(map_file)}\" alt=\"the map of the run\" style=\"width:100%\">"]
        if gif_file:
            body += [f"<p><img class=\"animation\" src=\"{e(gif_file)}\" alt=\"the run, animated\" "
                     "style=\"max-width:100%\"></p>"]
    if g.runs:
        body += _runs(g, assignment)
    elif g.status != HOSTILE and g.path.endswith(YAML_SUFFIXES):  # it did not run: how the grader would run it
        commands = "\n".join(run_command(g, assignment, seed) for seed in assignment.seeds)
        body += ["<h2>Running it as the grader does</h2>",
                 "<p>In your file's folder, with the grader's params and seeds:</p>",
                 f"<pre class=\"commands\">{e(commands)}</pre>"]
    body += _lists(g, warnings)
    return _page(f"{title}: {g.student}", body)


def _runs(g: Grade, assignment: Assignment) -> list[str]:
    """Each seed's run: what it did, its first fault, and the command that makes it again."""
    names = list(dict.fromkeys(m for r in g.runs for m in r.measured))
    own = list(dict.fromkeys(m for r in g.runs for m in r.metrics))
    distance = any(r.distance_m is not None for r in g.runs)
    rows = []
    for r in g.runs:
        fault = first_fault([r])
        rows.append([e(r.seed), e(r.status), e(r.ticks), e(f"{r.sim_time_s:.1f} s"), "yes" if r.stopped else "no",
                     e(r.collisions), *([e(_number(r.distance_m) + " m") if r.distance_m is not None else ""]
                                        if distance else []),
                     *(e(_number(r.measured.get(m))) for m in names), *(e(_number(r.metrics.get(m))) for m in own),
                     e(fault[1]) if fault else "none"])
    header = ["seed", "status", "ticks", "simulated", "stopped", "collisions", *(["driven"] if distance else []),
              *map(e, names), *(e(f"{m} (yours)") for m in own), "first fault (rule, tick, robot)"]
    commands = "\n".join(run_command(g, assignment, r.seed) for r in g.runs)
    return ["<h2>Runs</h2>", "<div style=\"overflow-x:auto\">" + _table(header, rows) + "</div>",
            "<p>To watch a run again, in your file's folder (the grader's params and seed):</p>",
            f"<pre class=\"commands\">{e(commands)}</pre>"]


def _lists(g: Grade, warnings: list[Diagnostic]) -> list[str]:
    """Rules that never fired, faults, warnings and log lines, each apart."""
    out: list[str] = []
    never = [set(r.never_fired) for r in g.runs if r.status == "ran"]
    unused = sorted(set.intersection(*never)) if never else []
    compiled = [d.format() for d in warnings]
    firsts = {c.splitlines()[0] for c in compiled}  # the run repeats the compiler's warnings
    run_warnings = [w for w in dict.fromkeys(w for r in g.runs for w in r.warnings)
                    if w and w.splitlines()[0] not in firsts]
    first = g.runs[0] if g.runs else None
    sections = (("Rules that never fired (on any seed)", unused),
                ("Runtime faults", list(dict.fromkeys(f for r in g.runs for f in r.faults))),
                ("Warnings", compiled + run_warnings),
                (f"Log lines (seed {first.seed if first else ''})", list(first.logs[:50]) if first else []))
    for heading, items in sections:
        if items:
            out += [f"<h2>{e(heading)}</h2>", "<pre>" + e("\n".join(items)) + "</pre>"]
    return out


def overview_page(graded: Graded, charts: list[str]) -> str:
    """The class at a glance; see the module docstring."""
    a = graded.assignment
    counts: dict[str, int] = {}
    for g in graded.grades:
        counts[g.status] = counts.get(g.status, 0) + 1
    order = {s: i for i, s in enumerate(STATUSES)}
    statuses = sorted(counts, key=lambda s: (order.get(s.split(":")[0], len(order)), s))
    scored = [g for g in graded.grades if g.criteria]
    passes = [[f"<strong>{e(c.name)}</strong>" + (" (required)" if c.required else ""), e(c.describe()),
               e(f"{sum(r.passed for g in scored for r in g.criteria if r.name == c.name)} of {len(scored)}")]
              for c in a.criteria]
    body = [f"<h1>{e(a.title)}: the class</h1>",
            *(f"<p class=\"fail\"><strong>The assignment: {e(w)}</strong></p>" for w in graded.warnings),
            f"<p>{len(graded.grades)} submissions, {len(a.seeds)} seed{'s' * (len(a.seeds) > 1)} each "
            f"({e(', '.join(map(str, a.seeds)))}); the grader's params: "
            f"{e(', '.join(f'{k} = {v}' for k, v in a.params.items()) or 'none')}</p>",
            "<h2>Status</h2>", _table(["status", "students"], [[e(s), e(counts[s])] for s in statuses]),
            "<h2>Criteria</h2>", _table(["criterion", "what passes", "passed (of the students who ran)"], passes),
            "<h2>Distributions</h2>", "<div class=\"charts\">"
            + "".join(f"<img src=\"{e(c)}\" alt=\"{e(Path(c).stem)}\">" for c in charts) + "</div>"]
    if a.measure:
        body += ["<h2>What the grader measures</h2>",
                 _table(["metric", "what it measures", "formula"],
                        [[e(m), e(metric_words(a, m)[0] + (f" ({metric_words(a, m)[2]})" if metric_words(a, m)[2]
                                                          else "")), f"<code>{e(a.definition(m))}</code>"]
                         for m in a.measured])]
    if graded.collisions:
        body += ["<h2>Names that collide</h2>", "<p class=\"muted\">these submissions would have had one name; "
                 "each has its own row and page under the name shown</p>",
                 _table(["students"], [[e(", ".join(group))] for group in graded.collisions])]
    if graded.skipped:
        body += ["<h2>Passed over</h2>", "<p class=\"muted\">found in the submissions folders, but no student's "
                 "submission</p>", _table(["file", "why"], [[e(p), e(why)] for p, why in graded.skipped])]
    if graded.copies:
        body += ["<h2>Likely copies</h2>", "<p class=\"muted\">for you to look at; not a verdict</p>",
                 _table(["what matched", "students"], [[e(why), e(", ".join(s))] for why, s in graded.copies])]
    pages = page_names([g.student for g in graded.grades])
    rows = [[f"<a href=\"feedback/{e(pages[g.student])}\">{e(g.student)}</a>", e(_number(g.score)),
             e(g.status), e(g.reason[:160]), e(" | ".join(messages(g))[:160])] for g in graded.grades]
    body += ["<h2>Students</h2>", _table(["student", "score", "status", "reason", "messages"], rows)]
    return _page(f"{a.title}: the class", body)


def charts(graded: Graded, folder: Path, inputs: list[str]) -> list[Path]:
    """A histogram of the score and of each metric's mean over the students who ran (SVG)."""
    folder.mkdir(parents=True, exist_ok=True)
    a = graded.assignment
    series = {"score (of 100)": [g.score for g in graded.grades if g.score is not None]}
    for m in a.measured:
        unit = metric_words(a, m)[2]
        series[f"{m}{f' ({unit})' if unit else ''}"] = [
            g.measured[m] for g in graded.grades if g.criteria and math.isfinite(g.measured.get(m, math.nan))]
    for m in a.metrics:
        series[f"{m} (students')" if m in a.measured else m] = [
            g.means[m] for g in graded.grades if g.criteria and math.isfinite(g.means.get(m, math.nan))]
    out = []
    for i, (name, values) in enumerate(series.items()):
        path = folder / f"{i:02d}.svg"  # numbered: a metric's name never becomes a file name
        svg = histogram_svg(f"{name}: {len(values)} students", values, "#3b6ea8" if i else "#2f8f4e")
        write_output(path, svg, inputs, "--out")
        (folder / f"{i:02d}.png").unlink(missing_ok=True)  # a last grading's, drawn by matplotlib
        out.append(path)
    for stale in sorted(folder.glob("*.svg"))[len(out):]:  # a last grading's, with more metrics
        stale.unlink()
    return out


def _ours(path: Path) -> bool:
    """Whether a file in --out is a page the grader wrote (a regular file, not a link, that
    begins as its pages do): only those are ever removed."""
    try:
        if path.is_symlink() or not path.is_file():
            return False
        return read_head(path, len(PAGE_HEAD.encode()), "page").decode("utf-8", "replace") == PAGE_HEAD
    except (OSError, LabsimError):
        return False


def _starts(path: Path, head: bytes) -> bool:
    """Whether a regular file (never a link) begins with ``head``."""
    try:
        return read_head(path, len(head), "chart") == head
    except (OSError, LabsimError):
        return False


def remove_stale_pages(out: Path, keep: set[str], overview: bool) -> None:
    """Remove the pages a last grading wrote in ``out`` that this one does not (a student gone,
    a page renamed; with ``overview`` False, --no-pages, every page and the overview): each
    feedback page the grader wrote, its map and animation beside it, and the overview with its
    charts. Nothing else is touched, so a teacher's own files in --out stay."""
    feedback = out / "feedback"
    for page in sorted(feedback.glob("*.html")) if feedback.is_dir() else []:
        if page.name in keep or not _ours(page):
            continue
        for picture in (page.with_suffix(".png"), page.with_suffix(".gif")):
            if picture.is_file() and not picture.is_symlink():
                picture.unlink()
        page.unlink()
    if not overview and _ours(out / "index.html"):
        (out / "index.html").unlink()
        charts = out / "charts"
        for chart in sorted(charts.glob("[0-9][0-9].svg")) if charts.is_dir() else []:
            if chart.is_file() and not chart.is_symlink() and _starts(chart, b"<svg "):
                chart.unlink()


def write_pages(out: Path, graded: Graded, inputs: list[str]) -> list[Path]:
    """The overview (``index.html``), its charts, and a feedback page per student, with the map
    and the animation of their first seed beside it when its worker drew them."""
    feedback = out / "feedback"
    feedback.mkdir(parents=True, exist_ok=True)
    written = []
    pages = page_names([g.student for g in graded.grades])
    remove_stale_pages(out, set(pages.values()), overview=True)
    for g in graded.grades:
        name = pages[g.student]
        png, gif = name.removesuffix(".html") + ".png", name.removesuffix(".html") + ".gif"
        map_png, animation_gif = graded.pictures.get(g.student, (b"", b""))
        for file, data in ((png, map_png), (gif, animation_gif)):
            if data:
                write_output(feedback / file, data, inputs, "--out")
            else:  # a last grading's: never shown beside this one's page
                (feedback / file).unlink(missing_ok=True)
        shown = (png, gif if animation_gif else None) if map_png else None
        path = feedback / name
        write_output(path, feedback_page(g, graded.assignment, shown, graded.reference), inputs, "--out")
        written.append(path)
    pictures = charts(graded, out / "charts", inputs)
    index = out / "index.html"
    write_output(index, overview_page(graded, [f"charts/{p.name}" for p in pictures]), inputs, "--out")
    return [index, *written]
