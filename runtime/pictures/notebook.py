"""The pictures a notebook shows of a run: its map (PNG) and, when asked, a short animation (GIF).

What ``labsim.run(...)``'s summary draws in Jupyter (``labsim.runtime.api.RunSummary``): the
map as ``labsim plot`` draws it, and the run played back ``GIF_SECONDS`` long, as a feedback
page's. The API finds it by name when a summary is first shown (the tick loop imports no application).
"""
from __future__ import annotations

import cv2

from labsim.runtime.pictures.animate import gif_bytes
from labsim.runtime.pictures.plot import render_figure
from labsim.runtime.trace import Trace, trace_world

MAP_WIDTH_PX = 700
GIF_WIDTH_PX, GIF_FPS, GIF_SECONDS = 480, 8, 6


def notebook_pictures(trace: Trace, animation: bool) -> tuple[bytes, bytes]:
    """The map's PNG, and the animation's GIF when asked (else b"")."""
    world, note = trace_world(trace)
    figure = render_figure(trace, width_px=MAP_WIDTH_PX, world=world, world_note=note)
    ok, data = cv2.imencode(".png", figure.image)
    png = data.tobytes() if ok else b""
    gif = b""
    if animation and trace.rows and "time" in trace.columns:
        recorded = trace.numbers.get("time")
        i = trace.columns.index("time")
        first, last = ((float(recorded[0]), float(recorded[-1])) if recorded is not None
                       else (float(trace.rows[0][i]), float(trace.rows[-1][i])))
        gif = gif_bytes(trace, width_px=GIF_WIDTH_PX, fps=GIF_FPS, speed=max(last - first, 1e-3) / GIF_SECONDS,
                        world=(world, note))
    return png, gif
