"""A feedback page's two pictures of a run: its map (PNG) and a short animation (GIF), as bytes.

What ``labsim grade`` draws of each student's first seed, in the worker that ran it, from the
run recorded in memory (``labsim.runtime.recording``) and the world the run used, so that no
trace is written or read: the map as ``labsim plot`` draws it, and the run played back as
``labsim plot -o run.gif`` plays it, ``GIF_SECONDS`` long at ``GIF_FPS`` frames a second and
``GIF_WIDTH_PX`` wide. The command line hands this function to the grader (applications do not
import each other).
"""
from __future__ import annotations

import cv2

from labsim.backends.scene.world import World
from labsim.runtime.pictures.animate import gif_bytes
from labsim.runtime.pictures.plot import render_figure
from labsim.runtime.trace import Trace

MAP_WIDTH_PX = 960
GIF_WIDTH_PX, GIF_FPS, GIF_SECONDS = 400, 5, 3  # 16 frames, about 60 kB


def feedback_pictures(trace: Trace, world: World | None, world_note: str = "") -> tuple[bytes, bytes]:
    """The map's PNG and the animation's GIF (b"" when the run has no time to play)."""
    figure = render_figure(trace, width_px=MAP_WIDTH_PX, world=world, world_note=world_note)
    ok, data = cv2.imencode(".png", figure.image)
    png = data.tobytes() if ok else b""
    gif = b""
    if trace.rows and "time" in trace.columns:
        recorded = trace.numbers.get("time")  # a recorded run's times are numbers only
        i = trace.columns.index("time")
        first, last = ((float(recorded[0]), float(recorded[-1])) if recorded is not None
                       else (float(trace.rows[0][i]), float(trace.rows[-1][i])))
        duration_s = last - first
        gif = gif_bytes(trace, width_px=GIF_WIDTH_PX, fps=GIF_FPS, speed=max(duration_s, 1e-3) / GIF_SECONDS,
                        world=(world, world_note))
    return png, gif
