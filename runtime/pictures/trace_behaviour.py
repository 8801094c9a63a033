"""The behaviour file a trace was made by, for the pictures that need more than the trace.

A stage after the run, beside the pictures that read the behaviour: the mechanism's poses and
slew panel (``labsim.runtime.pictures.mechanism_pose``), the camera's mount
(``labsim.runtime.pictures.camera_strip``) and a chart's units
(``labsim.runtime.pictures.signals``). The file is, in this order: the one ``labsim plot
--behaviour PATH`` names; the one the header names, or a file of its name beside the trace,
inside the folders docs/security.md lets a trace name; or the lab labsim ships that the header
names, wherever labsim is installed (``labsim.runtime.labs.shipped_behaviour``), which is
labsim's own file and needs no ``--allow-path``. When there is none, ``missing_note`` says what
a picture lacks and how to get it.
"""
from __future__ import annotations

import dataclasses
import hashlib
import os
import sys
from pathlib import Path

from labsim.foundation.diagnostics import LabsimError
from labsim.foundation.files import allowed_folders, policy_problem, read_text
from labsim.foundation.inert import inert
from labsim.foundation.yaml_data import load_data
from labsim.runtime.labs import behaviour_path, shipped_behaviour
from labsim.runtime.trace import Trace

OPTION = "--behaviour"


def behaviour_file(trace: Trace) -> Path | None:
    """The behaviour file that made the trace (see the module's docstring), or None."""
    if trace.behaviour_given:
        return Path(trace.behaviour_given)
    named = str(trace.header.get("behaviour") or "")
    folder = Path(trace.path).parent
    if named:
        path = Path(named)
        # docs/security.md: a path a trace names is read only inside the trace's folder, the
        # current one or an --allow-path folder (a trace is a file someone may have sent)
        allowed = [folder.resolve(), *allowed_folders()]
        for candidate in (path, folder / path, folder / path.name):
            if os.path.isfile(candidate) and not policy_problem(str(candidate), Path.cwd(), allowed):
                return candidate
    return shipped_behaviour(named, str(trace.header.get("sha256") or ""))


def behaviour_data(trace: Trace, warn: bool = True) -> tuple[str, dict]:
    """The text and top-level mapping of the behaviour that made the trace, read by labsim's one
    YAML reader (``labsim.foundation.yaml_data``); ("", {}) when there is none, or when the reader
    refuses it: then (``warn``) a warning on stderr says where and why, and the pictures go on."""
    path = behaviour_file(trace)
    if path is None:
        return "", {}
    try:
        text, data = load_data(path, "behaviour")
    except LabsimError as e:
        if warn:
            d = e.diagnostics[0] if e.diagnostics else None
            where = f"{inert(str(path))}:{d.line}:{d.col}" if d is not None and d.line else inert(str(path))
            why = inert(d.message) if d is not None else "refused"
            sys.stderr.write(f"{where}: warning: {why}; the pictures are drawn without this file\n")
        return "", {}
    return text, data if isinstance(data, dict) else {}


def given_behaviour(trace: Trace, argument: str) -> tuple[Trace, str]:
    """The trace with the behaviour file the command line names for it (a path or a lab's name),
    and a warning when that file is not the one the run used; LabsimError if it cannot be read."""
    path = behaviour_path(argument)
    text = read_text(path, "behaviour")  # a missing or unreadable file: exit 2, in words
    recorded = str(trace.header.get("sha256") or "")
    note = ""
    if recorded and hashlib.sha256(text.encode()).hexdigest() != recorded:
        note = (f"{OPTION} {argument}: this file is not the one the run used (it was edited since, or is "
                "another file): the pictures read it as it is now")
    return dataclasses.replace(trace, behaviour_given=str(path)), note


def not_found(trace: Trace) -> str:
    """Why ``behaviour_file`` found nothing and what to do, in words that follow 'the trace ...'."""
    named = str(trace.header.get("behaviour") or "")
    if not named:
        return f"names no behaviour file; pass {OPTION} PATH"
    if os.path.isfile(named):
        return (f"names {named}, outside the trace's folder and the current one, which labsim reads only if "
                f"you name it: {OPTION} {named} (or --allow-path {Path(named).parent}, docs/security.md)")
    return f"names {named}, which is not there; pass {OPTION} PATH"


def missing_note(trace: Trace, parts: list[str]) -> str:
    """What a picture is drawn without for want of the behaviour file, and how to get it."""
    what = parts[0] if len(parts) == 1 else ", ".join(parts[:-1]) + " and " + parts[-1]
    return (f"drawn without {what}, which need{'s' if len(parts) == 1 else ''} the behaviour file that made "
            f"the trace: the trace {not_found(trace)}")
