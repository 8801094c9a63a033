"""The cost of watching: the wall lab at "as fast as it goes" with a page connected, against `labsim run`.

    python benchmarks/bench_view.py [--repeat 5] [--rays python] [--view python]

Both sides run behaviours/wall_follow.yaml (30,000 ticks, no trace) on the pymunk backend.
The view side serves it as `labsim view` does (the aiohttp server, the pacing loop, a
WebSocket client in the same process receiving every frame it is sent, with its camera
images) and plays it at "max" until the run ends. It prints the median CPU times of the two,
alternated in random order, the median of the per-round ratios of ticks a second, the view's
over labsim run's (goal >= 0.8), the frames a second the page received (goal <= 30), the
bytes a frame averaged with its full path and chart samples (goal < 4096), and checks that
both ended at the same pose. ``--rays python`` has both sides cast the sonars with the Python
rays, not the C kernel: a simulator three times slower, against which the same cost of watching
weighs a third as much. ``--view python`` has the view record its ticks and make its chart's
envelope in Python, as an install without a C compiler does (runtime/view/_tap.c not built).
"""
from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import math
import statistics
import sys
import time
from pathlib import Path

import aiohttp

sys.path.insert(0, str(Path(__file__).resolve().parent))
from compare import Pose, alternate, labsim_side, machine, report

from labsim.runtime.view.live import LiveSession
from labsim.runtime.view.server import bind_socket, serve

LAB = Path(__file__).resolve().parent.parent / "behaviours" / "wall_follow.yaml"


async def _watched() -> tuple[float, list[Pose], float, float]:
    session = LiveSession(LAB, {}, warn=lambda m: None)
    assert session.load(), session.problems
    sock = bind_socket("127.0.0.1", 0)
    url = f"http://127.0.0.1:{sock.getsockname()[1]}"
    server = asyncio.ensure_future(serve(session, sock, url, log=lambda m: None))
    frames = 0
    sent = 0  # bytes of the frames received
    async with aiohttp.ClientSession() as http:
        for _ in range(200):
            try:
                ws = await http.ws_connect(url + "/ws")
                break
            except aiohttp.ClientConnectorError:
                await asyncio.sleep(0.01)
        await ws.receive_json()  # the scene
        await ws.send_str(json.dumps({"type": "speed", "value": "max"}))
        start = time.process_time()
        wall = time.perf_counter()
        await ws.send_str(json.dumps({"type": "play"}))
        while True:
            text = (await ws.receive()).data
            msg = json.loads(text)
            if msg["type"] == "frame" and msg["ran"] > 0:
                frames += 1
                sent += len(text.encode())
                if msg["finished"]:
                    break
        elapsed = time.process_time() - start
        wall = time.perf_counter() - wall
        assert session.observed is not None
        poses = [session.observed.pose(0)]
        await ws.close()
    server.cancel()
    with contextlib.suppress(asyncio.CancelledError):
        await server
    session.close()
    return elapsed, poses, frames / wall, sent / max(1, frames)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--rays", choices=("c", "python"), default="c",
                        help="the sonars' caster on both sides (c: the kernel where built)")
    parser.add_argument("--view", choices=("c", "python"), default="c",
                        help="what records the view's ticks (c: the extension where built)")
    args = parser.parse_args()
    if args.view == "python":
        from labsim.runtime.view import peaks

        peaks.KERNEL = "python"
    if args.rays == "python":
        from labsim.backends.pymunk import ray_cast

        ray_cast._kernel = None
    poses: dict[str, list[Pose]] = {}
    rates: list[float] = []
    sizes: list[float] = []

    def plain() -> float:
        t, poses["run"] = labsim_side(LAB, 1)
        return t

    def watched() -> float:
        t, poses["view"], rate, size = asyncio.run(_watched())
        rates.append(rate)
        sizes.append(size)
        return t

    print(machine())
    print(f"sonars cast by: {'the Python rays' if args.rays == 'python' else 'the C kernel'}; "
          f"the view's ticks recorded in {'Python' if args.view == 'python' else 'C'}")
    times = alternate({"labsim run": plain, "labsim view + page": watched}, args.repeat)
    same = all(math.isclose(a, b, rel_tol=0, abs_tol=1e-12)
               for p, q in zip(poses["run"], poses["view"]) for a, b in zip(p, q))
    report('wall lab, 30,000 ticks at "as fast as it goes"', times, ("labsim run", "labsim view + page"),
           ">= 0.8: ticks a second, the view's over labsim run's")
    print(f"  frames a second      {max(rates):.1f} at most, wall clock   (goal <= 30)")
    print(f"  bytes a frame        {statistics.median(sizes):,.0f} (median of the runs' averages; goal < 4096)")
    print(f"  same final pose: {'yes' if same else 'NO'}")

if __name__ == "__main__":
    main()
