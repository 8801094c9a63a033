"""Plain data from labsim's one YAML reader, for the readers that want values, not positions.

A picture reading the behaviour a trace names, or the shell's Tab completing ``--set``, needs
a file's ``let:`` or ``params:`` as dicts and strings; it gets them from the same composer the
compiler uses (``labsim.foundation.source.loads``: the size capped, aliases and anchors refused,
nesting capped at ``MAX_DEPTH``), never from ``yaml.safe_load``, which expands a 600-byte alias
bomb into gigabytes and recurses until Python's stack runs out. The nodes are turned into
values without recursion.
"""
from __future__ import annotations

from pathlib import Path

from yaml.nodes import MappingNode, Node, ScalarNode, SequenceNode

from labsim.foundation.files import read_text
from labsim.foundation.source import MAX_BYTES, loads, scalar_value


def load_data(path: str | Path, kind: str = "behaviour") -> tuple[str, object]:
    """A labsim YAML file's text and its plain value (dicts, lists, scalars); LabsimError, with
    the place, for a file the reader refuses."""
    text = read_text(path, kind, MAX_BYTES)
    return text, plain(loads(text, str(path)).root)


def plain(root: Node | None) -> object:
    """A composed node as Python values: a mapping a dict (keys as text), a list a list."""
    if root is None:
        return None
    made: dict[int, object] = {}
    order: list[Node] = []
    todo = [root]
    while todo:  # children before parents, by a reversed pre-order
        node = todo.pop()
        order.append(node)
        if isinstance(node, MappingNode):
            todo.extend(v for _, v in node.value)
        elif isinstance(node, SequenceNode):
            todo.extend(node.value)
    for node in reversed(order):
        if isinstance(node, MappingNode):
            made[id(node)] = {str(k.value) if isinstance(k, ScalarNode) else "": made[id(v)] for k, v in node.value}
        elif isinstance(node, SequenceNode):
            made[id(node)] = [made[id(v)] for v in node.value]
        else:
            made[id(node)] = scalar_value(node) if isinstance(node, ScalarNode) else None
    return made[id(root)]
