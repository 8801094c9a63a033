"""Animation files written frame by frame: an MP4 through ffmpeg, a GIF with one palette.

The last step of ``labsim.runtime.pictures.animate``: each frame (BGR, as OpenCV draws it) goes to
the file as soon as it is made and is then dropped, so that memory stays flat whatever the number
of frames. An MP4 is piped to ffmpeg (H.264, yuv420p, which browsers play) through imageio-ffmpeg,
converted to yuv420p here (only the boxes that changed since the last frame), by a thread of its
own: the next frames are drawn while ffmpeg takes the last ones, so that drawing and encoding
share the wall time instead of adding up (a few frames wait in between, so memory stays flat). A
GIF gets one palette for the whole animation, chosen once from a sample of what the frames show
(the backdrop, the run's last frame), instead of a palette per frame (or, for a feedback page's
short GIF, from the world's background and the colours a run draws, made once a process per world:
``run_palette``); each frame is mapped to it
without dithering (flat colours stay flat), and only the box that changed since the previous frame
is written, as Pillow's own animated GIFs do.
"""
from __future__ import annotations

import functools
import queue
import threading
from collections.abc import Generator, Sequence
from pathlib import Path
from typing import BinaryIO, Protocol

import cv2
import numpy as np
from PIL import GifImagePlugin, Image

# x264's fastest: for these flat pictures 30% less CPU than veryfast, at the same rate factor the
# same picture (PSNR 38.4 against veryfast's 37.4 dB on a wall-lab frame, no visible difference),
# in files about 2.7 times larger (some 30 kB a second of video)
PRESET = "ultrafast"
QUEUED = 8  # frames converted and waiting for ffmpeg at most (about 0.7 MB each at 720 px)
COMMON = 96  # a GIF palette's entries taken by the sample's most frequent colours, exactly
BLEND_UNDER = 8  # a run palette's blends: over the background's this many most frequent colours
GROUND_COLOURS = 24  # a run palette's background colours kept exactly (the octree has the rest)
RUN_COLOURS = 48  # and of the run's first this many colours (a fleet's others come from the octree)
Colour = tuple[int, int, int]  # BGR


Box = tuple[int, int, int, int]  # x0, y0, x1, y1 pixels, x1 and y1 excluded


class MovieWriter(Protocol):
    def append(self, frame: np.ndarray, changed: list[Box] | None = None) -> None:
        """One more frame: (h, w, 3) uint8, BGR, the size of the first; ``changed``: the boxes
        outside which it equals the frame before (None: anywhere)."""

    def close(self) -> None:
        """Finish the file (the rest of the encoder's output, a GIF's trailer)."""


class Mp4Writer:
    """H.264 through an ffmpeg child process, fed by a thread of its own."""

    def __init__(self, path: Path, size: tuple[int, int], fps: float):
        import imageio_ffmpeg

        # quality None: ffmpeg's default rate factor, as imageio's writer used before
        # frames go in as yuv420p, converted here (OpenCV's BT.601, the range ffmpeg's own
        # conversion uses): half the bytes through the pipe, and no conversion in ffmpeg
        self._gen: Generator[None, bytes | None, None] = imageio_ffmpeg.write_frames(
            str(path), size, pix_fmt_in="yuv420p", pix_fmt_out="yuv420p", fps=fps, codec="libx264",
            quality=None, macro_block_size=16, ffmpeg_log_level="error", output_params=["-preset", PRESET])
        self._gen.send(None)  # starts ffmpeg
        self._frames: queue.Queue[bytes | None] = queue.Queue(QUEUED)
        self._failed: BaseException | None = None
        self._yuv: np.ndarray | None = None  # the last frame converted, updated where frames change
        self._thread = threading.Thread(target=self._feed, name="labsim-mp4", daemon=True)
        self._thread.start()

    def _feed(self) -> None:
        """The thread: each frame to ffmpeg (a pipe write, which waits while ffmpeg is busy and
        lets the drawing go on meanwhile), until None; then ffmpeg is finished."""
        try:
            while (data := self._frames.get()) is not None:
                self._gen.send(data)
            self._gen.close()
        except BaseException as e:  # ffmpeg gone: told to the drawing side at its next frame
            self._failed = e
            while self._frames.get() is not None:  # let a waiting append go on to see it
                pass

    def append(self, frame: np.ndarray, changed: list[Box] | None = None) -> None:
        # converted here: the frame is drawn over by the next one, the converted copy is not
        self._check()
        self._yuv = to_i420(frame, changed, self._yuv)
        self._frames.put(self._yuv.tobytes())

    def close(self) -> None:
        if self._thread.is_alive():
            self._frames.put(None)
            self._thread.join()
        self._check()

    def _check(self) -> None:
        if self._failed is not None:
            failed, self._failed = self._failed, None
            raise failed


def to_i420(frame: np.ndarray, changed: list[Box] | None, last: np.ndarray | None) -> np.ndarray:
    """The frame in I420 (yuv420p: the Y plane, then U and V at half size each way), as
    ``cv2.cvtColor(frame, COLOR_BGR2YUV_I420)`` gives it. With the last frame's conversion and the
    boxes where the frames differ, only those boxes are converted (widened to even pixels: a
    chroma sample stands for a 2x2 block, which OpenCV converts alone) and written over ``last``:
    an animation's frame changes in a few small boxes, and converting all of it was 0.6 ms a
    frame, a quarter of the drawing thread's time."""
    h, w = frame.shape[:2]
    if changed is None or last is None or last.shape != (h * 3 // 2, w):
        return cv2.cvtColor(frame, cv2.COLOR_BGR2YUV_I420)
    flat = last.reshape(-1)
    y_plane, u_plane = flat[: h * w].reshape(h, w), flat[h * w: h * w * 5 // 4].reshape(h // 2, w // 2)
    v_plane = flat[h * w * 5 // 4:].reshape(h // 2, w // 2)
    for x0, y0, x1, y1 in dict.fromkeys(changed):  # a box restored and drawn again comes twice
        x0, y0 = max(x0, 0) & ~1, max(y0, 0) & ~1
        x1, y1 = min(x1 + (x1 & 1), w), min(y1 + (y1 & 1), h)
        if x0 >= x1 or y0 >= y1:
            continue
        bh, bw = y1 - y0, x1 - x0
        part = cv2.cvtColor(np.ascontiguousarray(frame[y0:y1, x0:x1]), cv2.COLOR_BGR2YUV_I420).reshape(-1)
        y_plane[y0:y1, x0:x1] = part[: bh * bw].reshape(bh, bw)
        u_plane[y0 // 2: y1 // 2, x0 // 2: x1 // 2] = part[bh * bw: bh * bw * 5 // 4].reshape(bh // 2, bw // 2)
        v_plane[y0 // 2: y1 // 2, x0 // 2: x1 // 2] = part[bh * bw * 5 // 4:].reshape(bh // 2, bw // 2)
    return last


class GifWriter:
    """An animated GIF, looping, one global palette, each frame's changed box only: the palette
    of a ``sample`` of what the frames show, or one given (``palette_image``, ``run_palette``)."""

    def __init__(self, file: BinaryIO, sample: np.ndarray | None, fps: float, palette: Image.Image | None = None):
        self._file = file
        self._duration_ms = 1000 / fps
        if palette is None:
            assert sample is not None, "a GIF needs a sample of its frames or a palette"
            palette = palette_image(sample)
        self._palette = palette
        self._colours = palette.getpalette() or []  # once: each frame's piece carries it
        self._last: np.ndarray | None = None

    def append(self, frame: np.ndarray, changed: list[Box] | None = None) -> None:
        # the palette is in BGR order like the frames; only the file's colour table is turned to RGB
        idx = np.asarray(Image.fromarray(frame, "RGB").quantize(palette=self._palette, dither=Image.Dither.NONE))
        if self._last is None:
            self._header(idx.shape[1], idx.shape[0])
            box = (0, 0, idx.shape[1], idx.shape[0])
        else:
            box = _changed(self._last, idx)
        self._last = idx
        x0, y0, x1, y1 = box
        part = Image.fromarray(np.ascontiguousarray(idx[y0:y1, x0:x1]), "L")
        part.putpalette(self._colours)
        for chunk in GifImagePlugin.getdata(part, offset=(x0, y0), duration=self._duration_ms):
            self._file.write(chunk)

    def _header(self, width: int, height: int) -> None:
        bgr = self._colours[: 3 * 256]
        bgr += [0] * (3 * 256 - len(bgr))
        rgb = np.array(bgr, np.uint8).reshape(-1, 3)[:, ::-1].tobytes()
        self._file.write(b"GIF89a" + width.to_bytes(2, "little") + height.to_bytes(2, "little")
                         + bytes((0xF7, 0, 0)) + rgb)
        self._file.write(b"!\xff\x0bNETSCAPE2.0\x03\x01\x00\x00\x00")  # loop for ever

    def close(self) -> None:
        self._file.write(b";")


def _changed(before: np.ndarray, after: np.ndarray) -> tuple[int, int, int, int]:
    """The smallest box holding every pixel that differs (one pixel when none does: a GIF frame
    cannot be empty, and its duration still counts)."""
    diff = before != after
    rows, cols = np.flatnonzero(diff.any(axis=1)), np.flatnonzero(diff.any(axis=0))
    if not len(rows):
        return (0, 0, 1, 1)
    return (int(cols[0]), int(rows[0]), int(cols[-1]) + 1, int(rows[-1]) + 1)


class _Same:
    """An array as a cache key by identity (arrays are not hashable), kept alive by the cache so
    that its id is not reused while the key is there."""

    def __init__(self, array: np.ndarray):
        self.array = array

    def __hash__(self) -> int:
        return id(self.array)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, _Same) and other.array is self.array


def run_palette(background: np.ndarray, colours: Sequence[Colour]) -> Image.Image:
    """A palette for an animation drawn on ``background`` (read-only, the same array for every
    run of a world at one size: ``Figure.background``) with ``colours`` (what the run adds: its
    paths, robots, markers, text), made without looking at the frames, so that it is made once a
    process for every run of a world rather than from each run's frames: ``colours`` and the
    background's most frequent colours exactly, the rest from an octree over the background and
    every blend of two of them in eighths (the antialiased edges of a colour drawn over another)."""
    return _run_palette(_Same(background), tuple(colours))


@functools.lru_cache(maxsize=8)
def _run_palette(background: _Same, colours: tuple[Colour, ...]) -> Image.Image:
    base = background.array
    pixels = base.reshape(-1, 3)
    packed = (pixels[:, 0].astype(np.uint32) << 16) | (pixels[:, 1].astype(np.uint32) << 8) | pixels[:, 2]
    values, counts = np.unique(packed, return_counts=True)
    common = values[np.argsort(counts, kind="stable")[::-1][:GROUND_COLOURS]]
    ground = [((int(v) >> 16) & 255, (int(v) >> 8) & 255, int(v) & 255) for v in common]
    run = list(dict.fromkeys(colours))[:RUN_COLOURS]
    exact = list(dict.fromkeys([*run, *ground]))[:256 - 64]  # and at least 64 for the edges between
    under = np.array([*run, *ground[:BLEND_UNDER]], float)  # the run's colours and the ground they lie on
    a = np.arange(1, 8)[:, None, None] / 8
    pairs = under[None, :, None, :] * a[..., None] + under[None, None, :, :] * (1 - a[..., None])
    # the blends weigh as much as the background in the octree: few pixels each, but on every edge
    blends = np.round(pairs).astype(np.uint8).reshape(-1, 3)
    sample = np.vstack((pixels, np.tile(blends, (max(1, len(pixels) // len(blends)), 1))))
    rest = Image.fromarray(np.ascontiguousarray(sample.reshape(-1, 1, 3)), "RGB").quantize(
        256 - len(exact), method=Image.Quantize.FASTOCTREE)
    more = rest.getpalette() or []
    found = exact + [tuple(more[3 * k: 3 * k + 3]) for k in range(len(more) // 3)]
    flat = [v for c in list(dict.fromkeys(found))[:256] for v in c]
    pal = Image.new("P", (1, 1))
    pal.putpalette(flat + [0] * (3 * 256 - len(flat)))
    return pal


def palette_image(sample: np.ndarray) -> Image.Image:
    """A 256-colour palette for the sample's colours, as a "P" image Pillow quantizes to: its
    most frequent colours exactly (the paper, the floor, grid, walls, paths, text), the rest
    from an octree over all of it (the antialiased edges between them)."""
    pixels = sample.reshape(-1, 3)
    packed = (pixels[:, 0].astype(np.uint32) << 16) | (pixels[:, 1].astype(np.uint32) << 8) | pixels[:, 2]
    values, counts = np.unique(packed, return_counts=True)
    common = values[np.argsort(counts, kind="stable")[::-1][:COMMON]]
    colours = [((int(v) >> 16) & 255, (int(v) >> 8) & 255, int(v) & 255) for v in common]
    rest = Image.fromarray(np.ascontiguousarray(sample), "RGB").quantize(256 - len(colours),
                                                                       method=Image.Quantize.FASTOCTREE)
    more = rest.getpalette() or []
    colours += [tuple(more[3 * k: 3 * k + 3]) for k in range(len(more) // 3)]  # type: ignore[misc]
    colours = list(dict.fromkeys(colours))[:256]
    flat = [v for c in colours for v in c]
    pal = Image.new("P", (1, 1))
    pal.putpalette(flat + [0] * (3 * 256 - len(flat)))
    return pal
