"""``labsim sweep --plot``: each metric across the settings, a box per setting with every run on it.

A panel per metric; in each, one box plot per group of runs (file and settings: the median,
the quartiles, whiskers to 1.5 x the interquartile range) with each run drawn as a dot beside
the box (jittered sideways, so that equal values stay visible), and the group's best marked
in its title. Drawn with matplotlib's object API on an Agg canvas: no pyplot state, no
display. matplotlib is the optional ``plot`` extra; runtime/sweep/driver.py checks it is
there before any run starts.
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from labsim.foundation.files import save_figure

PANEL_WIDTH_IN, PANEL_HEIGHT_IN = 5.0, 3.4
COLUMNS = 2


def plot_comparison(comp: dict[str, Any], path: str) -> None:
    """Write the chart of a sweep's comparison (runtime/sweep/stats.py ``comparison``) to ``path``."""
    import numpy as np
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    metrics: list[str] = comp["metrics"]
    groups = comp["groups"]
    several_files = len({g.file for g in groups}) > 1
    labels = [_label(g, several_files) for g in groups]
    cols = min(COLUMNS, max(1, len(metrics)))
    rows = max(1, math.ceil(len(metrics) / cols))
    width = max(PANEL_WIDTH_IN, 0.6 * len(groups)) * cols
    fig = Figure(figsize=(width, PANEL_HEIGHT_IN * rows + 0.6), layout="constrained")
    FigureCanvasAgg(fig)
    rng = np.random.default_rng(0)  # the jitter; fixed so the same sweep draws the same chart
    axes = fig.subplots(rows, cols, squeeze=False)
    for k, ax in enumerate(axes.flat):
        if k >= len(metrics):
            ax.set_visible(False)
            continue
        m = metrics[k]
        data = [[v for v in g.values.get(m, []) if math.isfinite(v)] for g in groups]
        positions = list(range(1, len(groups) + 1))
        shown = [(p, d) for p, d in zip(positions, data) if d]
        if shown:
            ax.boxplot([d for _, d in shown], positions=[p for p, _ in shown], widths=0.5, showfliers=False,
                       medianprops={"color": "black"}, boxprops={"color": "0.35"}, whiskerprops={"color": "0.35"},
                       capprops={"color": "0.35"})
        for p, d in shown:
            ax.scatter(p + 0.32 + rng.uniform(-0.06, 0.06, len(d)), d, s=12, alpha=0.7, color="tab:blue",
                       edgecolors="none")
        slanted = len(groups) > 3
        ax.set_xticks(positions, labels, rotation=30 if slanted else 0, ha="right" if slanted else "center")
        if len(groups) > 1:
            for i in comp["best"].get(m, []):
                ax.get_xticklabels()[i].set_fontweight("bold")
        better = comp["better"].get(m)
        goal = f"{better.value} is better; best in bold" if better is not None else "no direction declared"
        ax.set_title(f"{m}  ({goal})" if len(groups) > 1 else m, fontsize=10)
        ax.grid(axis="y", alpha=0.3)
    runs = sum(g.runs for g in groups)
    fig.suptitle(f"labsim sweep: {runs} runs, {len(groups)} group{'s' if len(groups) != 1 else ''}", fontsize=11)
    save_figure(fig, Path(path), dpi=110)


def _label(group: Any, several_files: bool) -> str:
    setting = group.label or "(as in the file)"
    return f"{Path(group.file).stem}\n{setting}" if several_files else setting
