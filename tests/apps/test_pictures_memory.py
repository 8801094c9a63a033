"""Plots in bounded memory: a long trace is read a chunk at a time and thinned, an animation is
written frame by frame; the peak resident memory of a `labsim plot` process is measured."""
from __future__ import annotations

import subprocess
import sys
import tempfile
from pathlib import Path

import pytest
from helpers import BEHAVIOURS, measured_command, measured_result

from labsim.runtime.pictures.trace_sample import read_for_picture
from labsim.runtime.trace import read_trace

MIB = 1024 * 1024
GOLDEN = BEHAVIOURS / "wall_follow.golden.csv"


def long_trace(path: Path, megabytes: float) -> int:
    """The wall lab's golden rows again and again, ticks and times running on; the rows written."""
    lines = GOLDEN.read_text().splitlines(keepends=True)
    head, rows = lines[:2], lines[2:]
    ticks, n = len(rows), 0
    with path.open("w") as f:
        f.writelines(head)
        while f.tell() < megabytes * MIB:
            lap = n // ticks
            for row in rows:
                tick, _, rest = row.split(",", 2)
                t = int(tick) + lap * ticks
                f.write(f"{t},{t * 0.05:.6g},{rest}")
            n += ticks
    return n


def peak_mib(*args: str) -> float:
    """The peak resident memory of ``labsim ARGS`` in a process of its own (or its ffmpeg),
    taken by a small launcher (helpers.measured_command)."""
    report = Path(tempfile.mkdtemp()) / "peak"
    proc = subprocess.run(measured_command(report, [sys.executable, "-m", "labsim", *args]),
                          stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, check=False)
    err = proc.stderr.decode()
    code, peak = measured_result(report)
    assert code == 0, err
    assert "Traceback" not in err
    return peak


def test_a_trace_that_fits_is_read_whole_and_the_same() -> None:
    whole, (sampled, note) = read_trace(GOLDEN), read_for_picture(str(GOLDEN))
    assert note == "" and sampled.rows == whole.rows and sampled.lines == whole.lines
    assert sampled.header == whole.header and sampled.footer == whole.footer


def test_rows_read_in_batches_keep_their_lines_across_blank_lines_and_quoted_newlines(tmp_path: Path) -> None:
    # rows are taken from the csv reader in batches and their lines counted after: a quoted cell
    # with newlines and a blank line must leave every later row on its own line, as read_trace says
    text = GOLDEN.read_text().splitlines(keepends=True)
    state = text[1].split(",").index("state")
    cells = text[5].split(",")
    cells[state] = '"two\nlines"'
    text[5] = ",".join(cells)
    text.insert(9, "\n")
    path = tmp_path / "quoted.csv"
    path.write_text("".join(text))
    whole, (sampled, note) = read_trace(path), read_for_picture(str(path))
    assert note == "" and sampled.rows == whole.rows and sampled.lines == whole.lines
    assert sampled.rows[3][state] == "two\nlines" and sampled.lines[3:6] == [7, 8, 9]
    assert all(sampled.numbers[c].tolist() == [float(r[whole.columns.index(c)]) for r in whole.rows]
               for c in ("time", "x", "y", "heading"))


def test_a_long_trace_is_thinned_keeping_every_event_and_each_robot_s_last_row(tmp_path: Path) -> None:
    path = tmp_path / "long.csv"
    rows = long_trace(path, 12)
    trace, note = read_for_picture(str(path), max_kept=8 * MIB)
    assert f"{rows:,} rows" in note and len(trace.rows) < rows / 2
    ev = trace.columns.index("events")
    whole = read_trace(path)
    assert sum(1 for r in trace.rows if r[ev]) == sum(1 for r in whole.rows if r[ev])  # every event kept
    assert trace.rows[-1] == whole.rows[-1] and trace.lines == sorted(trace.lines)


@pytest.mark.slow
@pytest.mark.long
def test_plots_of_a_long_trace_stay_in_bounded_memory(tmp_path: Path) -> None:
    path = tmp_path / "long.csv"
    long_trace(path, 60)  # 430,000 rows: read whole, 16 times its size in text and lists
    png = peak_mib("plot", str(path), "-o", str(tmp_path / "map.png"))
    gif = peak_mib("plot", str(path), "-o", str(tmp_path / "run.gif"), "--fps", "100", "--to", "300")
    # the bound (docs/pictures.md): rows kept within twice 128 MiB, plus the modules and a frame
    assert png < 450 and gif < 450, (png, gif)
