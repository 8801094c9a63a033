"""A behaviour's size against the run's budgets: robots, camera pixels, world segments, image memory.

Checked when the file compiles, before any robot is placed (placing 10,000 robots at random
is itself quadratic) and before anything is simulated, each at its place in the file: the
robots at the group that goes past the budget, the pixels at the camera, the segments at
``world:``, the image memory at the signal where a tick's estimate first goes past it
(``labsim.dsl.analysis.image_memory``). The other budgets (ticks, trace size) are the tick loop's
(``labsim.runtime.run``). The budgets are the caller's, never the file's: see
``labsim.foundation.limits.Budgets``.
"""
from __future__ import annotations

from labsim.backends.scene.world import World
from labsim.dsl.analysis.check import Checked
from labsim.dsl.analysis.image_memory import lifetimes, peak_bytes
from labsim.foundation.diagnostics import Report
from labsim.foundation.limits import Budgets

MB = 1_000_000  # a budget's megabyte


def check_budgets(c: Checked, budgets: Budgets, report: Report) -> None:
    """Report each budget this behaviour's robots, cameras or world go past."""
    doc = c.file.doc
    robots = pixels = 0
    robots_said = pixels_said = False
    for decl in c.file.robots:
        robots += decl.count
        if robots > budgets.robots and not robots_said:
            robots_said = True
            total = sum(d.count for d in c.file.robots)
            report.add(doc.diagnostic(decl.key, f"{total} robots in all, more than this run's budget of "
                                      f"{budgets.robots}", notes=(_raise("robots", total),)))
        model = c.models.get(decl.name)
        if model is None:
            continue
        pixels += decl.count * sum(cam.width_px * cam.height_px for cam in model.cameras)
        if pixels > budgets.camera_px and not pixels_said:
            pixels_said = True
            report.add(doc.diagnostic(decl.key, f"the cameras render {pixels:,} pixels a tick with robot "
                                      f"'{decl.name}', more than this run's budget of {budgets.camera_px:,}",
                                      notes=("fewer or smaller cameras, or " + _raise("camera_px", pixels),)))
    if c.world is not None:
        segments = world_segments(c.world)
        if segments > budgets.segments:
            report.add(doc.diagnostic(c.file.world_node, f"world '{c.world.name}' has {segments:,} segments "
                                      f"(walls, block edges, road chords and lines), more than this run's "
                                      f"budget of {budgets.segments:,}", notes=(_raise("segments", segments),)))
    check_memory(c, budgets, report)


def check_memory(c: Checked, budgets: Budgets, report: Report) -> None:
    """Report the signal at which a tick's image memory goes past the run's ``memory_mb``."""
    peak = peak_bytes(c, lifetimes(c))
    at = peak.first_over(budgets.memory_mb * MB)
    if at < 0:
        return
    name, parsed = c.lets[at]
    needed = -(-peak.bytes // MB)
    value = parsed.text.value
    report.add(parsed.text.diagnostic(0, len(value), (
        f"with signal '{name}' the images alive need more than this run's memory budget of "
        f"{budgets.memory_mb:,} MB (every robot's, camera images included; about {needed:,} MB at the "
        f"tick's peak)"), notes=(
        "an image a rule, the stop condition or a metric reads is kept all tick; one only other signals "
        "read is freed after the last of them", "smaller cameras, fewer image signals, or "
        + _raise("memory_mb", needed))))


def world_segments(world: World) -> int:
    """The straight pieces a world is simulated and drawn from, arcs already made chords."""
    count = len(world.walls) + sum(len(b.corners) for b in world.blocks)
    if world.ground is not None:
        g = world.ground
        count += sum(len(r.points) - (0 if r.closed else 1) for r in g.roads)
        count += len(g.lines) + sum(len(p.corners) for p in g.patches)
    if world.mechanism is not None:
        count += len(world.mechanism.bodies) + len(world.mechanism.joints)
    return count


def _raise(name: str, needed: int) -> str:
    return f"if the file is right, raise the budget where it runs: --budget {name}={needed}"
