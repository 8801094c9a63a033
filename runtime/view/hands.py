"""A page's hands on the world: a drag of a robot or a block, a block added or removed.

``LiveSession`` (``labsim.runtime.view.live``) hands the page's ``place`` and ``block``
messages here. Each is checked (a robot's index, a block's number, finite numbers), turned
into a change (``labsim.runtime.hands``) and made through ``Run.hand``, which sends it to the
backend and records it in the trace; a refusal (an overlap with a wall or a robot, a point
outside the world, a backend that cannot) raises ``ChangeRefused`` with a sentence the page
shows, and changes nothing. ``blocks_doc`` is the frame's list of blocks once any changed.
"""
from __future__ import annotations

import math

from labsim.runtime.hands import BlockAdd, BlockMove, BlockRemove, Hand, Place
from labsim.runtime.run import Run
from labsim.runtime.view.session import BadMessage, ChangeRefused, finite

NEW_BLOCK_M = 0.5  # an added block's side when the page does not say


def place_message(run: Run, msg: dict) -> tuple[int, float, float]:
    """Put a robot at a pose (a drag on the canvas); the robot's index and where it now is."""
    robot = msg.get("robot")
    if isinstance(robot, bool) or not isinstance(robot, int) \
            or not 0 <= robot < len(run.robots) or run.robots[robot].model is None:
        raise BadMessage("'robot' must be the index of a robot (not a mechanism)")
    x, y = finite(msg.get("x"), "x"), finite(msg.get("y"), "y")
    heading = math.remainder(finite(msg.get("heading"), "heading"), math.tau)
    x0, y0, x1, y1 = run.program.world.bounds
    # far outside, a simulator's numbers stop meaning anything (and chipmunk may abort)
    why = "it is outside the world" if not (x0 - 1 <= x <= x1 + 1 and y0 - 1 <= y <= y1 + 1) \
        else run.hand(Place(run.robots[robot].name, x, y, heading))
    if why is not None:
        raise ChangeRefused([f"{run.robots[robot].name} was not moved to ({x:.2f}, {y:.2f}): {why}"])
    return robot, x, y


def block_message(run: Run, msg: dict) -> None:
    """Move a block (its centre to x, y), add one (at x, y, ``width`` by ``depth``) or remove one."""
    op = msg.get("op")
    hands = run.hands_on
    hand: Hand
    if op == "add":
        size = [finite(msg.get(k, NEW_BLOCK_M), k) for k in ("width", "depth")]
        hand = BlockAdd(hands.next_block, finite(msg.get("x"), "x"), finite(msg.get("y"), "y"), *size)
        what = f"a block was not added at ({hand.x_m:.2f}, {hand.y_m:.2f})"
    elif op in ("move", "remove"):
        k = msg.get("block")
        if isinstance(k, bool) or not isinstance(k, int) or k not in hands.blocks:
            raise BadMessage("'block' must be the number of a block there is")
        if op == "remove":
            hand, what = BlockRemove(k), f"block {k} was not removed"
        else:
            hand = BlockMove(k, finite(msg.get("x"), "x"), finite(msg.get("y"), "y"))
            what = f"block {k} was not moved to ({hand.x_m:.2f}, {hand.y_m:.2f})"
    else:
        raise BadMessage("'op' must be 'move', 'add' or 'remove'")
    why = run.hand(hand)
    if why is not None:
        raise ChangeRefused([f"{what}: {why}"])


def blocks_doc(run: Run) -> list[list[object]] | None:
    """The blocks as they stand, ``[number, [[x, y], ...]]`` each, once any has changed (else
    None: the scene's are the blocks)."""
    hands = run.hands_on
    if not hands.changed:
        return None
    return [[k, [list(c) for c in corners]] for k, corners in hands.blocks.items()]
