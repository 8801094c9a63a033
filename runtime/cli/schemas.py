"""The JSON Schemas as files: what ``labsim schema`` prints and the shipped labs point editors at.

The schemas are built by ``labsim.dsl.syntax.schema`` (behaviour files) and
``labsim.backends.scene.schema`` (world files) and ``labsim.runtime.grade.assignment``
(a grader's assignment files) from the readers' key tables; this module writes
them as text, the same text as the copies shipped beside the labs (``behaviours/*.schema.json``,
which tests/unit/test_schema.py keeps equal to it). A lab file's first line,
``# yaml-language-server: $schema=behaviour.schema.json``, points yaml-language-server (VS
Code's YAML extension and others) at the copy beside it.
"""
from __future__ import annotations

import json

from labsim.backends.scene.schema import Schema, world_schema
from labsim.dsl.syntax.schema import behaviour_schema

MODELINE = "# yaml-language-server: $schema="


def schema(kind: str) -> Schema:
    if kind == "assignment":  # the grader's (runtime/grade), read only when asked for
        from labsim.runtime.grade.assignment_schema import assignment_schema

        return assignment_schema()
    return behaviour_schema() if kind == "behaviour" else world_schema()


def schema_text(kind: str) -> str:
    return json.dumps(schema(kind), indent=2, ensure_ascii=False) + "\n"


def file_name(kind: str) -> str:
    return f"{kind}.schema.json"
