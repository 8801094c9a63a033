"""The class overview's charts: a histogram of one metric over the students, as a small SVG file.

Drawn by ``labsim.runtime.grade.pages`` for the overview page, as matplotlib drew them before
(the same bins as ``numpy.histogram``, which matplotlib's ``hist`` uses, the same size, colours,
title and axes), but as text: importing matplotlib and drawing its figures cost about 1.4 s of
CPU a grading, a third of the pages' cost for a class of 40 (docs/decisions.md
§23). The names in a chart are escaped; the SVG holds no script or link.
"""
from __future__ import annotations

import html
import math

import numpy as np

WIDTH, HEIGHT = 400, 260  # px, as matplotlib's figsize=(4, 2.6) at 100 dpi
LEFT, RIGHT, TOP, BOTTOM = 52, 12, 30, 28  # the plot's margins, px


def nice_ticks(low: float, high: float, most: int = 6) -> list[float]:
    """Round tick values within [low, high], at most about ``most`` of them, a step of 1, 2 or 5
    times a power of ten."""
    span = high - low
    if not (math.isfinite(span) and span > 0):
        return [low] if math.isfinite(low) else []
    raw = span / most
    power = 10.0 ** math.floor(math.log10(raw))
    step = next(k * power for k in (1, 2, 2.5, 5, 10) if k * power >= raw)
    first = math.ceil(low / step - 1e-9)
    return [round(k * step, 12) for k in range(first, math.floor(high / step + 1e-9) + 1)]


def _label(value: float) -> str:
    return f"{value:.6g}"


def histogram_svg(title: str, values: list[float], colour: str) -> str:
    """An SVG histogram of ``values`` titled ``title`` (escaped), bars in ``colour`` (a "#rrggbb")."""
    bins = min(20, max(5, len(values) // 2))
    counts, edges = np.histogram(np.asarray(values, dtype=float), bins=bins)
    x0, x1 = float(edges[0]), float(edges[-1])
    pad = (x1 - x0) * 0.05  # matplotlib's margins beside the bars
    lo, hi = x0 - pad, x1 + pad
    top = max(1, int(counts.max()) if len(counts) else 1) * 1.05
    pw, ph = WIDTH - LEFT - RIGHT, HEIGHT - TOP - BOTTOM

    def px(x: float) -> float:
        return LEFT + (x - lo) / (hi - lo) * pw

    def py(c: float) -> float:
        return TOP + ph - c / top * ph

    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{WIDTH}" height="{HEIGHT}" '
           f'viewBox="0 0 {WIDTH} {HEIGHT}" font-family="DejaVu Sans, sans-serif">',
           f'<rect width="{WIDTH}" height="{HEIGHT}" fill="#fff"/>',
           f'<text x="{LEFT + pw / 2:.1f}" y="{TOP - 9}" font-size="13" text-anchor="middle">'
           f'{html.escape(title)}</text>']
    for c, a, b in zip(counts.tolist(), edges[:-1].tolist(), edges[1:].tolist()):
        if c:
            out.append(f'<rect x="{px(a):.2f}" y="{py(c):.2f}" width="{px(b) - px(a):.2f}" '
                       f'height="{py(0) - py(c):.2f}" fill="{colour}" shape-rendering="crispEdges"/>')
    out.append(f'<rect x="{LEFT}" y="{TOP}" width="{pw}" height="{ph}" fill="none" stroke="#000" stroke-width="0.8"/>')
    for t in nice_ticks(lo, hi):
        x = px(t)
        out.append(f'<line x1="{x:.2f}" y1="{TOP + ph}" x2="{x:.2f}" y2="{TOP + ph + 3.5}" stroke="#000" '
                   'stroke-width="0.8"/>'
                   f'<text x="{x:.2f}" y="{TOP + ph + 15}" font-size="10" text-anchor="middle">{_label(t)}</text>')
    for t in nice_ticks(0, top):
        if t != int(t):  # a count is whole
            continue
        y = py(t)
        out.append(f'<line x1="{LEFT - 3.5}" y1="{y:.2f}" x2="{LEFT}" y2="{y:.2f}" stroke="#000" stroke-width="0.8"/>'
                   f'<text x="{LEFT - 6}" y="{y + 3.5:.2f}" font-size="10" text-anchor="end">{int(t)}</text>')
    out.append(f'<text x="14" y="{TOP + ph / 2:.1f}" font-size="12" text-anchor="middle" '
               f'transform="rotate(-90 14 {TOP + ph / 2:.1f})">students</text></svg>\n')
    return "".join(out)
