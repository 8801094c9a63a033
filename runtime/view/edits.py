"""What the page's editor and Parameters panel send, checked before the live session uses it.

``live.LiveSession`` applies an edited file or new parameters by recompiling, and saves the
editor's text over the view's own file; the checks of those messages (sizes, kinds, finite
numbers) and the guarded write live here, apart from the session's ticking and frames.
"""
from __future__ import annotations

import math
import os
from pathlib import Path

from labsim.foundation.diagnostics import LabsimError
from labsim.foundation.files import write_output
from labsim.runtime.view.session import BadMessage, ChangeRefused, name

MAX_EDIT_CHARS = 60_000  # an edited file the page sends (its messages are at most 64 KiB)


def edited_text(msg: dict) -> str:
    """The file's text an apply or save message carries."""
    text = msg.get("text")
    if not isinstance(text, str) or len(text) > MAX_EDIT_CHARS:
        raise BadMessage(f"'text' must be the file's text, at most {MAX_EDIT_CHARS:,} characters")
    return text


def save_over(path: str, text: str, inputs: list[str | Path], can_save: bool) -> None:
    """Write the text over the view's own file, atomically: never over its world or trace
    (``inputs``), never through a link, never from a view without its session token."""
    if not can_save:
        raise ChangeRefused([f"{path}: not saved: this view was started with --no-token, so any program "
                             "that reaches its port could write the file; start labsim view without "
                             "--no-token to save from the page"])
    if os.path.islink(path):
        raise ChangeRefused([f"{path}: not saved: it is a link; save it in an editor"])
    try:
        write_output(path, text, inputs)
    except LabsimError as e:
        raise ChangeRefused([d.format() for d in e.diagnostics]) from None


def wanted_params(msg: dict, overrides: dict[str, str]) -> dict[str, str]:
    """The overrides with the Parameters panel's values: each a name and a finite number."""
    values = msg.get("values")
    if not isinstance(values, dict) or len(values) > 200:
        raise BadMessage("'values' must be an object of parameter names and values")
    wanted = dict(overrides)
    for key, value in values.items():
        key = name(key, "a parameter name")
        if isinstance(value, bool) or not isinstance(value, (str, int, float)) or len(str(value)) > 100:
            raise BadMessage(f"parameter '{key}' needs a number")
        if isinstance(value, float) and not math.isfinite(value):
            raise BadMessage(f"parameter '{key}' needs a finite number")
        wanted[key] = str(value)
    return wanted
