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
from collections.abc import Iterable
from pathlib import Path

from labsim.foundation.diagnostics import Diagnostic
from labsim.foundation.files import write_output
from labsim.foundation.inert import inert
from labsim.runtime.grade.contract import STATUSES
from labsim.runtime.grade.gradebook import messages, page_names
from labsim.runtime.grade.histogram import histogram_svg
from labsim.runtime.grade.score import Grade, Graded

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


def _page(title: str, body: list[str]) -> str:
    return ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            f"<meta http-equiv=\"Content-Security-Policy\" content=\"{CSP}\">"
            f"<title>{e(title)}</title><style>{STYLE}</style></head><body>\n" + "\n".join(body) + "\n</body></html>\n")


def _number(value: float | None) -> str:
    if value is None:
        return ""
    return "nan" if not math.isfinite(value) else f"{value:.4g}"


def _table(header: Iterable[str], rows: Iterable[Iterable[str]]) -> str:
    """A table of cells already escaped (the callers escape what they put in)."""
    head = "".join(f"<th>{h}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td>{c}</td>" for c in row) + "</tr>" for row in rows)
    return f"<table><tr>{head}</tr>{body}</table>"


def feedback_page(g: Grade, title: str, pictures: tuple[str, str | None] | None, reference: Grade | None) -> str:
    """One student's page; see the module docstring."""
    score = f"{g.score:g} / 100" if g.score is not None else "not graded"
    body = [f"<h1>{e(title)}: {e(g.student)}</h1>",
            f"<p><span class=\"status\">{e(g.status)}</span> <strong>{e(score)}</strong></p>"]
    if g.reason:
        body.append(f"<p>{e(g.reason)}</p>")
    errors = [d for d in g.diagnostics if d.severity == "error"]
    warnings = [d for d in g.diagnostics if d.severity != "error"]
    if errors:
        shown = "\n".join(d.format() for d in errors)
        body += ["<h2>Errors in the file</h2>", f"<pre class=\"diagnostics\">{e(shown)}</pre>"]
    if g.criteria:
        ref = {r.name: r for r in reference.criteria} if reference is not None else {}
        rows = [[e(r.description), e(_number(r.value)) if r.value is not None else "",
                 e(_number(ref[r.name].value)) if r.name in ref and ref[r.name].value is not None else "",
                 f"<span class=\"{'pass' if r.passed else 'fail'}\">{'pass' if r.passed else 'fail'}</span>",
                 e(f"{r.points:.3g} / {r.weight:g}")] for r in g.criteria]
        body += ["<h2>Criteria</h2>", _table(["criterion", "your value (mean over the seeds)",
                                              "reference" if reference is not None else "", "", "points"], rows)]
    if pictures:
        map_file, gif_file = pictures
        body += ["<h2>The map of seed " + e(g.runs[0].seed) + "</h2>",
                 f"<img class=\"map\" src=\"{e(map_file)}\" alt=\"the map of the run\" style=\"max-width:100%\">"]
        if gif_file:
            body += [f"<p><img class=\"animation\" src=\"{e(gif_file)}\" alt=\"the run, animated\" "
                     "style=\"max-width:100%\"></p>"]
    if g.runs:
        names = list(dict.fromkeys(m for r in g.runs for m in r.metrics))
        rows = [[e(r.seed), e(r.status), e(r.ticks), e(f"{r.sim_time_s:.1f} s"), "yes" if r.stopped else "no",
                 e(r.collisions), e(len(r.faults)), *(e(_number(r.metrics.get(m))) for m in names)] for r in g.runs]
        body += ["<h2>Runs</h2>", _table(["seed", "status", "ticks", "simulated", "stopped", "collisions",
                                          "faults", *map(e, names)], rows)]
    body += _lists(g, warnings)
    return _page(f"{title}: {g.student}", body)


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
    counts = {s: sum(g.status == s for g in graded.grades) for s in STATUSES}
    body = [f"<h1>{e(a.title)}: the class</h1>",
            f"<p>{len(graded.grades)} submissions, {len(a.seeds)} seed{'s' * (len(a.seeds) > 1)} each "
            f"({e(', '.join(map(str, a.seeds)))}); criteria: {e('; '.join(c.describe() for c in a.criteria))}</p>",
            "<h2>Status</h2>", _table(["status", "students"], [[e(s), e(n)] for s, n in counts.items() if n]),
            "<h2>Distributions</h2>", "<div class=\"charts\">"
            + "".join(f"<img src=\"{e(c)}\" alt=\"{e(Path(c).stem)}\">" for c in charts) + "</div>"]
    if graded.collisions:
        body += ["<h2>Names that collide</h2>", "<p class=\"muted\">these submissions would have had one name; "
                 "each has its own row and page under the name shown</p>",
                 _table(["students"], [[e(", ".join(group))] for group in graded.collisions])]
    if graded.copies:
        body += ["<h2>Likely copies</h2>", "<p class=\"muted\">for you to look at; not a verdict</p>",
                 _table(["why", "students"], [[e(why), e(", ".join(s))] for why, s in graded.copies])]
    pages = page_names([g.student for g in graded.grades])
    rows = [[f"<a href=\"feedback/{e(pages[g.student])}\">{e(g.student)}</a>", e(_number(g.score)),
             e(g.status), e(g.reason[:160]), e(" | ".join(messages(g))[:160])] for g in graded.grades]
    body += ["<h2>Students</h2>", _table(["student", "score", "status", "reason", "messages"], rows)]
    return _page(f"{a.title}: the class", body)


def charts(graded: Graded, folder: Path, inputs: list[str]) -> list[Path]:
    """A histogram of the score and of each metric's mean over the graded students (SVG)."""
    folder.mkdir(parents=True, exist_ok=True)
    series = {"score": [g.score for g in graded.grades if g.score is not None]}
    for m in graded.assignment.metrics:
        series[m] = [g.means[m] for g in graded.grades if g.graded and math.isfinite(g.means.get(m, math.nan))]
    out = []
    for i, (name, values) in enumerate(series.items()):
        path = folder / f"{i:02d}.svg"  # numbered: a metric's name never becomes a file name
        svg = histogram_svg(f"{name} ({len(values)} graded)", values, "#3b6ea8" if i else "#2f8f4e")
        write_output(path, svg, inputs, "--out")
        (folder / f"{i:02d}.png").unlink(missing_ok=True)  # a last grading's, drawn by matplotlib
        out.append(path)
    return out


def write_pages(out: Path, graded: Graded, inputs: list[str]) -> list[Path]:
    """The overview (``index.html``), its charts, and a feedback page per student, with the map
    and the animation of their first seed beside it when its worker drew them."""
    feedback = out / "feedback"
    feedback.mkdir(parents=True, exist_ok=True)
    written = []
    pages = page_names([g.student for g in graded.grades])
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
        write_output(path, feedback_page(g, graded.assignment.title, shown, graded.reference), inputs, "--out")
        written.append(path)
    pictures = charts(graded, out / "charts", inputs)
    index = out / "index.html"
    write_output(index, overview_page(graded, [f"charts/{p.name}" for p in pictures]), inputs, "--out")
    return [index, *written]
