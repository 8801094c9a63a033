"""The overview's SVG histograms: numpy's bins, round ticks, every name escaped."""
from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np

from labsim.runtime.grade.histogram import histogram_svg, nice_ticks

SVG = "{http://www.w3.org/2000/svg}"


def test_the_bars_are_numpys_bins() -> None:
    values = [1.0, 1.5, 2.0, 2.0, 3.5, 4.0, 4.0, 4.0, 5.0, 6.0, 7.5, 8.0]
    root = ET.fromstring(histogram_svg("score (12 graded)", values, "#2f8f4e"))
    bars = [r for r in root.iter(f"{SVG}rect") if r.get("fill") == "#2f8f4e"]
    counts, _ = np.histogram(values, bins=6)
    assert len(bars) == int((counts > 0).sum())
    heights = [float(b.get("height", 0)) for b in bars]
    tallest = heights.index(max(heights))
    assert tallest == [i for i, c in enumerate(counts.tolist()) if c].index(int(counts.argmax()))


def test_a_name_is_escaped_and_no_values_is_still_a_chart() -> None:
    svg = histogram_svg("<script>alert(1)</script> (0 graded)", [], "#3b6ea8")
    root = ET.fromstring(svg)
    assert "<script>" not in svg and not list(root.iter(f"{SVG}script"))
    assert root.get("width") == "400"


def test_one_value_many_times_makes_one_bar() -> None:
    root = ET.fromstring(histogram_svg("m (9 graded)", [3.0] * 9, "#3b6ea8"))
    assert len([r for r in root.iter(f"{SVG}rect") if r.get("fill") == "#3b6ea8"]) == 1


def test_ticks_are_round() -> None:
    assert nice_ticks(22.7, 25.6) == [23.0, 23.5, 24.0, 24.5, 25.0, 25.5]
    assert nice_ticks(0, 8.4) == [0.0, 2.0, 4.0, 6.0, 8.0]
    assert nice_ticks(3.0, 3.0) == [3.0]
