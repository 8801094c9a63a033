"""``labsim run --trace run.mcap``: the CSV trace first, then the MCAP file made from it.

The run writes its CSV trace beside the MCAP file, and ``labsim.runtime.export`` turns it into
MCAP once the run ends (docs/mcap.md).
"""
from __future__ import annotations

import argparse
from pathlib import Path

from labsim.foundation.diagnostics import LabsimError
from labsim.foundation.files import check_output


def mcap_trace(args: argparse.Namespace, inputs: list[Path]) -> str | None:
    """``--trace``'s target checked; for ``run.mcap``, ``args.trace`` becomes the CSV trace the run
    writes first (``.run.mcap.csv`` beside it, removed once exported) and the MCAP name is returned."""
    if not args.trace:
        return None
    check_output(args.trace, inputs, "--trace")
    if Path(args.trace).suffix.lower() != ".mcap":
        return None
    out = args.trace
    args.trace = str(Path(out).with_name(f".{Path(out).name}.csv"))
    check_output(args.trace, inputs, "--trace")
    return str(out)


def export_run(csv_trace: str, out: str) -> LabsimError | None:
    """The run's CSV trace written as MCAP at ``out`` (the CSV removed); the error, if any, for
    after the summary. A run that made no rows leaves its CSV, which says so."""
    from labsim.runtime.export.mcap_file import export_trace

    try:
        export_trace(csv_trace, out)
    except LabsimError as e:
        return e
    Path(csv_trace).unlink(missing_ok=True)
    return None
