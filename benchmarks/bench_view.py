"""The cost of watching: the wall lab at "as fast as it goes" with a page connected, against `labsim run`.

    python benchmarks/bench_view.py [--repeat 5]

Both sides run behaviours/wall_follow.yaml (30,000 ticks, no trace) on the pymunk backend.
The view side serves it as `labsim view` does (the aiohttp server, the pacing loop, a
WebSocket client in the same process receiving every frame it is sent, with its camera
images) and plays it at "max" until the run ends. It prints the median wall times, their
ratio (goal <= 1.2), the frames a second the page received (goal <= 30), and checks that
both ended at the same pose.
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
from compare import Pose, labsim_side

from labsim.runtime.view.live import LiveSession
from labsim.runtime.view.server import bind_socket, serve

LAB = Path(__file__).resolve().parent.parent / "behaviours" / "wall_follow.yaml"


async def _watched() -> tuple[float, list[Pose], int]:
    session = LiveSession(LAB, {}, warn=lambda m: None)
    assert session.load(), session.problems
    sock = bind_socket("127.0.0.1", 0)
    url = f"http://127.0.0.1:{sock.getsockname()[1]}"
    server = asyncio.ensure_future(serve(session, sock, url, log=lambda m: None))
    frames = 0
    async with aiohttp.ClientSession() as http:
        for _ in range(200):
            try:
                ws = await http.ws_connect(url + "/ws")
                break
            except aiohttp.ClientConnectorError:
                await asyncio.sleep(0.01)
        await ws.receive_json()  # the scene
        await ws.send_str(json.dumps({"type": "speed", "value": "max"}))
        start = time.perf_counter()
        await ws.send_str(json.dumps({"type": "play"}))
        while True:
            msg = json.loads((await ws.receive()).data)
            if msg["type"] == "frame" and msg["tick"] > 0:
                frames += 1
                if msg["finished"]:
                    break
        elapsed = time.perf_counter() - start
        assert session.observed is not None
        poses = [session.observed.pose(0)]
        await ws.close()
    server.cancel()
    with contextlib.suppress(asyncio.CancelledError):
        await server
    session.close()
    return elapsed, poses, frames


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    plain, watched, rates = [], [], []
    for _ in range(args.repeat):  # interleaved, so both sides see the same machine load
        t, run_poses = labsim_side(LAB, 1)
        plain.append(t)
        t, view_poses, frames = asyncio.run(_watched())
        watched.append(t)
        rates.append(frames / t)
    same = all(math.isclose(a, b, rel_tol=0, abs_tol=1e-12)
               for p, q in zip(run_poses, view_poses) for a, b in zip(p, q))
    run_s, view_s = statistics.median(plain), statistics.median(watched)
    print(f"wall lab, 30,000 ticks at \"as fast as it goes\", median of {args.repeat}:")
    print(f"  labsim run           {run_s:.3f} s   ({', '.join(f'{t:.3f}' for t in plain)})")
    print(f"  labsim view + page   {view_s:.3f} s   ({', '.join(f'{t:.3f}' for t in watched)})")
    print(f"  ratio view / run     {view_s / run_s:.3f}   (goal <= 1.2)")
    print(f"  frames a second      {max(rates):.1f} at most   (goal <= 30)")
    print(f"  same final pose: {'yes' if same else 'NO'}")


if __name__ == "__main__":
    main()
