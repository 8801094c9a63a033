"""The JSON Schema of assignment files, for editors and ``labsim schema assignment``.

Written from the assignment reader's own key tables (``labsim.runtime.grade.assignment``), so
that what an editor completes and checks is what ``labsim grade`` reads.
"""
from __future__ import annotations

from labsim.backends.scene.schema import DRAFT, IDENTIFIER, Schema, mapping
from labsim.foundation.kinds import ASSIGNMENT_VERSION_KEY
from labsim.foundation.limits import Budgets
from labsim.foundation.numbers import WHOLE_LIMIT
from labsim.runtime.grade.assignment import (
    ANY,
    BUILTINS,
    CRITERION_KEYS,
    DEFAULT_TIMEOUT_S,
    KEYS,
    MAX_SEEDS,
    MAX_TIMEOUT_S,
    STUDENT,
)


def assignment_schema() -> Schema:
    """The JSON Schema of assignment files, from the reader's key tables (``labsim schema assignment``)."""
    number: Schema = {"type": "number"}
    criterion = mapping(CRITERION_KEYS, {
        "at_least": {**number, "description": "passes (full weight) when the metric's mean over the seeds is at "
                                              "least this"},
        "at_most": {**number, "description": "passes (full weight) when the mean is at most this"},
        "score": {"type": "array", "items": number, "minItems": 2, "maxItems": 2,
                  "description": "[worst, best]: 0 at worst, the full weight at best, linear between"},
        "weight": {**number, "exclusiveMinimum": 0, "description": "its share of the score (default 1)"},
        "required": {"type": "boolean", "description": "a gate: failing it gives the assignment's gate_score"},
        "from": {"const": STUDENT, "description": "a metric the student's file defines, not a measured one"}})
    out = mapping(KEYS, {
        ASSIGNMENT_VERSION_KEY: {"const": 1, "description": "the assignment format version"},
        "title": {"type": "string", "description": "the assignment's name in the gradebook and on the pages"},
        "world": {"type": "string", "description": "the world every submission uses, or 'any'"},
        "robots": {"oneOf": [{"type": "integer", "minimum": 0}, {"const": ANY}],
                   "description": "how many robots a submission runs, or 'any'"},
        "params": {"type": "object", "propertyNames": {"pattern": IDENTIFIER},
                   "additionalProperties": {"type": ["number", "boolean"]},
                   "description": "params every submission declares, with the values the grader sets"},
        "measure": {"type": "object", "propertyNames": {"pattern": IDENTIFIER},
                    "additionalProperties": {"oneOf": [
                        {"type": "string"},
                        {"type": "object", "additionalProperties": False, "required": ["value"],
                         "properties": {"value": {"type": "string"}, "better": {"enum": ["higher", "lower"]}}}]},
                    "description": "metrics the grader measures on every run, in the behaviour language's metric "
                                   "syntax, e.g. hits: count(collided); they read only sensors, the pose, time and "
                                   "the grader's params"},
        "gate_score": {"type": "number", "minimum": 0, "maximum": 100,
                       "description": "the score of a student who fails a required criterion (default 0)"},
        "metrics": {"type": "array", "items": {"type": "string", "pattern": IDENTIFIER},
                    "description": "metrics every submission defines (the criteria's are added)"},
        "seeds": {"type": "array", "items": {"type": "integer", "minimum": 0, "maximum": WHOLE_LIMIT}, "minItems": 1,
                  "maxItems": MAX_SEEDS, "uniqueItems": True, "description": "one run per seed (default [1])"},
        "timeout_s": {**number, "exclusiveMinimum": 0, "maximum": MAX_TIMEOUT_S,
                      "description": f"wall time each run may take (default {DEFAULT_TIMEOUT_S:g} s)"},
        "budgets": {"type": "object", "additionalProperties": False,
                    "properties": {n: {"type": "integer", "minimum": 0} for n in Budgets.names()},
                    "description": "each run's budgets (docs/security.md)"},
        "criteria": {"type": "object", "minProperties": 1, "additionalProperties": criterion,
                     "description": "a metric's name or a built-in (" + ", ".join(BUILTINS) + ") to how it "
                                    "scores"},
        "reference": {"type": "string", "description": "a behaviour whose metrics are shown beside each "
                                                       "student's (relative to this file)"},
    }, "A labsim assignment file (docs/grading.md).", required=(ASSIGNMENT_VERSION_KEY, "world", "robots",
                                                               "criteria"))
    return {"$schema": DRAFT, **out}


