"""How much image memory a tick needs, and when each image signal can be let go.

Between the checker and the code generator: ``lifetimes`` says, for each image signal, whether
something besides other signals reads it (a rule, the stop condition, a metric, a binding, a
label: then it is *kept* for the whole tick) or, if not, after which signal it is read for the
last time; ``labsim.dsl.emit.codegen`` frees it there (and a kept one as the next tick starts), so
a chain of image signals holds one or two images at a time, not all of them. ``peak_bytes``
follows the same lifetimes through a tick, one robot after another as a fleet runs, with each
image's size from its camera's resolution (RGB, 3 bytes a pixel; ``gray`` and ``threshold``
make one byte a pixel, ``crop`` keeps its whole source alive), and ``labsim.dsl.analysis.budget`` holds
the result against the run's ``memory_mb``. An estimate from above: every image a signal's expression makes on the way
counts as alive until the signal is done.
"""
from __future__ import annotations

import dataclasses
from collections.abc import Iterator
from dataclasses import dataclass
from typing import TypeGuard

from labsim.backends.scene.models import RobotModel
from labsim.dsl.analysis.check import Checked
from labsim.dsl.library.builtins import Type
from labsim.dsl.syntax import ast

ONE_CHANNEL = frozenset({"gray", "threshold"})  # image functions whose result is one byte a pixel
SAME_SHAPE = frozenset({"invert", "crop"})  # same shape as the argument (a crop is a view into it)
Shape = tuple[int, int]  # pixels, channels


@dataclass(frozen=True)
class Lifetimes:
    """The image signals and when each can go: ``drops[j]`` are freed after signal j."""

    images: tuple[str, ...]  # the image signals, in the file's order
    kept: frozenset[str]  # read by something besides signals: alive for the whole tick
    drops: dict[int, tuple[str, ...]]  # signal index -> the image signals read for the last time there


@dataclass(frozen=True)
class Peak:
    """A tick's image memory, from above: while each signal is evaluated, and at most."""

    at_signal: tuple[int, ...]  # bytes alive, every robot's, while signal j (of Checked.lets) is evaluated
    frames: int  # the camera images read this tick
    all_bytes: int  # every image signal of every robot held at once (what a live view shows)

    @property
    def bytes(self) -> int:
        return max(self.at_signal, default=self.frames)

    def first_over(self, limit: int) -> int:
        """The first signal at which the tick holds more than ``limit`` bytes; -1 for none."""
        return next((j for j, b in enumerate(self.at_signal) if b > limit), -1)


def lifetimes(c: Checked) -> Lifetimes:
    """Each image signal's last reader among the signals, unless something else reads it."""
    images = tuple(n for n, _ in c.lets if c.let_types.get(n) is Type.IMAGE and n not in c.group_sizes)
    if not images:
        return Lifetimes((), frozenset(), {})
    kept = frozenset(images) & _names_outside_signals(c)
    last: dict[str, int] = {}
    for j, (name, parsed) in enumerate(c.lets):
        if name in images:
            last.setdefault(name, j)
        for node in _nodes(parsed.node):
            if isinstance(node, ast.Name) and node.id in images:
                last[node.id] = j
    drops: dict[int, list[str]] = {}
    for name in images:
        if name not in kept:
            drops.setdefault(last[name], []).append(name)
    return Lifetimes(images, kept, {j: tuple(names) for j, names in drops.items()})


def peak_bytes(c: Checked, life: Lifetimes) -> Peak:
    """The most image memory a tick holds, every robot's signals evaluated before any acts."""
    groups = [(decl.count, c.models.get(decl.name)) for decl in c.file.robots]
    frames = sum(count * _frame_bytes(model, c.channels) for count, model in groups)
    per_group = [(count, _robot_profile(c, life, model)) for count, model in groups]
    kept_all = sum(count * kept for count, (kept, _, _) in per_group)
    every = sum(count * total for count, (_, _, total) in per_group)
    # while one robot evaluates signal j, each other robot holds its kept images
    at = tuple(frames + max((kept_all - kept + steps[j] for _, (kept, steps, _) in per_group), default=0)
               for j in range(len(c.lets)))
    return Peak(at, frames, frames + every)


def _robot_profile(c: Checked, life: Lifetimes, model: RobotModel | None) -> tuple[int, list[int], int]:
    """One robot's kept bytes, its bytes alive while each signal is evaluated, and all its images."""
    cameras = {cam.name: (cam.width_px * cam.height_px, 3) for cam in model.cameras} if model else {}
    biggest = max(cameras.values(), key=_size, default=(0, 3))
    shapes: dict[str, Shape] = {}
    transient: list[int] = []
    for name, parsed in c.lets:
        made = [_shape(c, n, cameras, shapes, biggest) for n in _nodes(parsed.node) if _makes_image(n, c)]
        transient.append(sum(_size(s) for s in made))
        if name in life.images:
            shapes[name] = _shape(c, parsed.node, cameras, shapes, biggest)
    kept = sum(_size(shapes[n]) for n in life.kept)
    # the kept images of the last tick are let go as the tick starts (codegen): signal j meets
    # this tick's images made so far and still held, and what it makes on the way
    steps, alive = [], 0
    for j, (name, _) in enumerate(c.lets):
        steps.append(alive + transient[j])
        if name in life.images:
            alive += _size(shapes[name])
        alive -= sum(_size(shapes[n]) for n in life.drops.get(j, ()))
    return kept, steps, sum(_size(s) for s in shapes.values())


def _makes_image(node: object, c: Checked) -> TypeGuard[ast.Expr]:
    """A node whose evaluation makes a new image: an image-valued call or choice."""
    return isinstance(node, (ast.Call, ast.IfExp)) and c.node_types.get(id(node)) is Type.IMAGE


def _shape(c: Checked, e: ast.Expr, cameras: dict[str, Shape], shapes: dict[str, Shape], biggest: Shape) -> Shape:
    """An image expression's pixels and channels; the robot's biggest camera when unknown."""
    if isinstance(e, ast.Name):
        return cameras.get(e.id) or shapes.get(e.id) or biggest
    if isinstance(e, ast.Call) and e.args and (e.func in ONE_CHANNEL or e.func in SAME_SHAPE):
        pixels, channels = _shape(c, e.args[0], cameras, shapes, biggest)
        return (pixels, 1) if e.func in ONE_CHANNEL else (pixels, channels)
    if isinstance(e, ast.IfExp):
        return max(_shape(c, e.body, cameras, shapes, biggest), _shape(c, e.orelse, cameras, shapes, biggest),
                   key=_size)
    return biggest


def _size(shape: Shape) -> int:
    return shape[0] * shape[1]


def _frame_bytes(model: RobotModel | None, channels: tuple[str, ...]) -> int:
    """A robot's camera images as read this tick."""
    if model is None:
        return 0
    return sum(cam.width_px * cam.height_px * 3 for cam in model.cameras if cam.name in channels)


def _names_outside_signals(c: Checked) -> frozenset[str]:
    """Every name something other than a signal reads: rules, stop, metrics, bindings, labels,
    function bodies."""
    roots = [c.states, c.metrics, c.file.stop, c.binds, c.labels, [f.body for f in c.functions.values()]]
    return frozenset(n.id for n in _nodes(roots) if isinstance(n, ast.Name))


def _nodes(root: object) -> Iterator[object]:
    """Every AST node under ``root``, found by walking dataclasses, lists, tuples and dicts whole
    (groups, indexes, log texts and any later kind of node included), without recursion."""
    todo = [root]
    while todo:
        item = todo.pop()
        if isinstance(item, (list, tuple)):
            todo.extend(item)
        elif isinstance(item, dict):
            todo.extend(item.values())
        elif dataclasses.is_dataclass(item) and not isinstance(item, type) and _walkable(item):
            yield item
            todo.extend(getattr(item, f.name) for f in dataclasses.fields(item))


def _walkable(item: object) -> bool:
    """The parts of a behaviour that hold expressions: AST nodes and the declarations around them."""
    return type(item).__module__ in ("labsim.dsl.syntax.ast", "labsim.dsl.syntax.read", "labsim.dsl.analysis.check")
