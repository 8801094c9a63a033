"""Write again every command output the README and the docs quote, from the commands themselves.

    python docs/regenerate.py            # run each quoted command and write its output in place
    python docs/regenerate.py --check    # say which quoted outputs differ from what the commands print
    python docs/regenerate.py wall-sweep # only the blocks of that recipe

A quoted output sits in a Markdown file between two comments naming its recipe::

    <!-- output: wall-sweep -->
    ```
    $ labsim sweep behaviours/wall_follow.yaml --set front=0.5,1.0 --seeds 1-20
    ...what it prints...
    ```
    <!-- end output -->

Each recipe below runs its command (from the repository root, or in a scratch folder it sets
up) and gives the block's text: the command line, then what it printed. What depends on the
machine (a run's wall time and real-time factor) is left as the command printed it when
written, and ignored when checked (``VOLATILE``); everything else, every number to the
precision printed, must be what the command prints today. tests/apps/test_docs_outputs.py runs
the check. After a change that moves a lab's figures, run this and commit the docs with it.
"""
from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
BLOCK = re.compile(r"(?P<open><!-- output: (?P<name>[\w-]+) -->\n```[a-z]*\n)(?P<body>.*?)"
                   r"(?P<close>```\n<!-- end output -->)", re.S)
# what a command prints that depends on the machine, not on the code: masked when checking
VOLATILE = [re.compile(r"in \d+(?:\.\d+)? s \([\d,.]+x real time\)")]


def labsim(*args: str, cwd: Path = ROOT, ok: tuple[int, ...] = (0,), stream: str = "stdout") -> str:
    """What ``labsim ARGS`` prints on ``stream``, run as a user runs it (its exit code one of ``ok``)."""
    env = {**os.environ, "COLUMNS": "200", "NO_COLOR": "1"}
    done = subprocess.run([sys.executable, "-m", "labsim", *args, "--no-progress"] if args[0] in ("run", "sweep")
                          else [sys.executable, "-m", "labsim", *args],
                          cwd=cwd, capture_output=True, text=True, env=env, timeout=3600)
    if done.returncode not in ok:
        raise RuntimeError(f"labsim {' '.join(args)} exited {done.returncode}:\n{done.stderr}")
    return done.stderr if stream == "stderr" else done.stdout


@dataclass(frozen=True)
class Recipe:
    shown: str  # the command line the block shows, after "$ " (empty: the block shows output only)
    make: Callable[[], str]  # what the command prints

    def text(self) -> str:
        out = self.make()
        return (f"$ {self.shown}\n" if self.shown else "") + out


def _golden_failure() -> str:
    """The wall lab copied as lab.yaml with its golden, ``side`` changed by 1 cm, checked."""
    with tempfile.TemporaryDirectory(prefix="labsim-docs-") as scratch:
        folder = Path(scratch)
        shutil.copy(ROOT / "behaviours" / "wall_follow.golden.csv", folder / "lab.golden.csv")
        text = (ROOT / "behaviours" / "wall_follow.yaml").read_text(encoding="utf-8")
        assert "side: 0.3 " in text, "the wall lab no longer sets side: 0.3; change this recipe"
        (folder / "lab.yaml").write_text(text.replace("side: 0.3 ", "side: 0.31", 1), encoding="utf-8")
        return labsim("test", "lab.yaml", cwd=folder, ok=(1,))


def _rule_code(rule: str) -> str:
    """The lines ``labsim check --show-code`` prints for one rule of the wall lab: its comment and
    the test under it (the first time it is written: ``decide`` comes before ``both``)."""
    lines = labsim("check", "behaviours/wall_follow.yaml", "--show-code").splitlines()
    at = next((i for i, line in enumerate(lines) if f": rule {rule}: " in line), None)
    assert at is not None, f"--show-code no longer has rule {rule}; change this recipe"
    return "\n".join(lines[at:at + 2]) + "\n"


BREAK = ("run", "behaviours/wall_follow.yaml", "--break", "min([sonar5, sonar2]) < 0.5")


def _trace_sample() -> str:
    """The head and the end of the trace a short run of the wall lab writes: its header (the first
    keys), its column line, its first row, its last row and its footer."""
    with tempfile.TemporaryDirectory(prefix="labsim-docs-") as scratch:
        trace = Path(scratch) / "run.csv"
        labsim("run", "behaviours/wall_follow.yaml", "--set", "minutes=0.05", "--trace", str(trace), "--quiet")
        lines = trace.read_text(encoding="utf-8").splitlines()
    header = lines[0].split(', "labsim"', 1)[0] + ", ...}"
    assert lines[-1].startswith("# end "), "a finished run's trace ends with its footer"
    return "\n".join([header, lines[1], lines[2], "...", lines[-2], lines[-1]]) + "\n"


def _world_outside(*worlds: str) -> str:
    """``labsim check b.yaml`` on the wall lab copied as b.yaml, its ``world:`` each of ``worlds`` in
    turn, in a folder beside ``teacher/w.yaml`` and ``other/sub``, with ``w.yaml`` a link to the
    teacher's world and ``d`` a link to ``../other/sub`` (docs/security.md)."""
    text = (ROOT / "behaviours" / "wall_follow.yaml").read_text(encoding="utf-8")
    assert "\nworld: walls_lab4\n" in text, "the wall lab no longer names walls_lab4; change this recipe"
    out = []
    with tempfile.TemporaryDirectory(prefix="labsim-docs-") as scratch:
        top = Path(scratch)
        for folder in ("student", "teacher", "other/sub"):
            (top / folder).mkdir(parents=True)
        shutil.copy(ROOT / "backends" / "scene" / "worlds" / "walls_lab4.yaml", top / "teacher" / "w.yaml")
        shutil.copy(top / "teacher" / "w.yaml", top / "other" / "w.yaml")
        (top / "student" / "w.yaml").symlink_to(top / "teacher" / "w.yaml")
        (top / "student" / "d").symlink_to(Path("..") / "other" / "sub")
        for world in worlds:
            (top / "student" / "b.yaml").write_text(text.replace("\nworld: walls_lab4\n", f"\nworld: {world}\n", 1),
                                                   encoding="utf-8")
            out.append(labsim("check", "b.yaml", cwd=top / "student", ok=(2,), stream="stderr"))
    return "".join(line + "\n" for o in out for line in o.splitlines() if ": error: " in line)


def _plot_without_behaviour() -> str:
    """``labsim plot`` of a crane trace whose behaviour file is gone: the crane lab copied to
    old/crane.yaml (a comment added, so that it is not the shipped lab by its content), run, removed."""
    with tempfile.TemporaryDirectory(prefix="labsim-docs-") as scratch:
        folder = Path(scratch)
        (folder / "old").mkdir()
        text = (ROOT / "behaviours" / "crane.yaml").read_text(encoding="utf-8")
        (folder / "old" / "crane.yaml").write_text(text + "# mine\n", encoding="utf-8")
        labsim("run", "old/crane.yaml", "--trace", "c.csv", "--quiet", cwd=folder)
        shutil.rmtree(folder / "old")
        return labsim("plot", "c.csv", "-o", "c.png", cwd=folder, stream="stderr")


DRIVE = """labsim: 1.2
name: Drive slowly or fast
world: walls_lab4
dt: 0.05
seed: 1
stop: time >= 2
robots:
  pioneer: {model: pioneer_p3dx, at: [0, 0, 0]}
params:
  speed: 1
rules:
  - always move(speed)
metrics:
  moving: duration(forward_speed > 0.15)
"""


def _sweep_no_direction() -> str:
    """``DRIVE`` shown, then swept over two speeds: a duration that declares no direction."""
    with tempfile.TemporaryDirectory(prefix="labsim-docs-") as scratch:
        (Path(scratch) / "drive.yaml").write_text(DRIVE, encoding="utf-8")
        swept = labsim("sweep", "drive.yaml", "--set", "speed=1,2", cwd=Path(scratch))
    return f"$ cat drive.yaml\n{DRIVE}$ labsim sweep drive.yaml --set speed=1,2\n{swept}"


def _plot_long() -> str:
    """``labsim plot`` of a 100-minute run of the wall lab, longer than a picture keeps whole."""
    with tempfile.TemporaryDirectory(prefix="labsim-docs-") as scratch:
        folder = Path(scratch)
        labsim("run", str(ROOT / "behaviours" / "wall_follow.yaml"), "--set", "minutes=100", "--trace", "long.csv",
               "--quiet", cwd=folder)
        return labsim("plot", "long.csv", "-o", "long.png", cwd=folder, stream="stderr")


SWEEP = ("sweep", "behaviours/wall_follow.yaml", "--set", "front=0.5,1.0", "--seeds", "1-20")
RECIPES: dict[str, Recipe] = {
    "wall-summary": Recipe("labsim run behaviours/wall_follow.yaml",
                           lambda: labsim("run", "behaviours/wall_follow.yaml")),
    "wall-sweep": Recipe("labsim " + " ".join(SWEEP), lambda: labsim(*SWEEP)),
    "golden-failure": Recipe("", _golden_failure),
    "wall-break": Recipe("labsim run behaviours/wall_follow.yaml --break 'min([sonar5, sonar2]) < 0.5'",
                         lambda: labsim(*BREAK)),
    "wall-rule-code": Recipe("", lambda: _rule_code("wander:1")),
    "trace-sample": Recipe("", _trace_sample),
    "plot-long": Recipe("", _plot_long),
    "sweep-no-direction": Recipe("", _sweep_no_direction),
    "plot-without-behaviour": Recipe("", _plot_without_behaviour),
    "world-outside": Recipe("", lambda: _world_outside("/etc/passwd", "../teacher/w.yaml", "w.yaml")),
    "world-through-link": Recipe("", lambda: _world_outside("d/../w.yaml")),
    "sweep-unknown-param": Recipe("", lambda: labsim("sweep", "behaviours/wall_follow.yaml", "--set", "fron=0.5",
                                                     ok=(2,), stream="stderr")),
    "grid-too-large": Recipe("", lambda: labsim("sweep", "behaviours/wall_follow.yaml", "--set", "front=0.5,1.0",
                                                "--seeds", "1-60000", ok=(2,), stream="stderr")),
}
# the recipes whose commands take minutes of CPU (the test marks their check long)
LONG = {"wall-sweep"}


@dataclass(frozen=True)
class Block:
    path: Path
    name: str
    body: str


def blocks(paths: list[Path] = DOCS) -> list[Block]:
    return [Block(p, m.group("name"), m.group("body")) for p in paths
            for m in BLOCK.finditer(p.read_text(encoding="utf-8"))]


def shown(path: Path) -> str:
    return str(path.relative_to(ROOT)) if path.is_relative_to(ROOT) else str(path)


def unmatched(paths: list[Path] = DOCS) -> list[str]:
    """Markers that open no well-formed block (no fence after them, no end marker): a block that
    would otherwise be skipped without a word."""
    out = []
    for path in paths:
        text = path.read_text(encoding="utf-8")
        opened, whole = len(re.findall(r"(?m)^<!-- output: ", text)), len(BLOCK.findall(text))
        if opened != whole or len(re.findall(r"(?m)^<!-- end output -->", text)) != whole:
            out.append(f"{shown(path)}: {opened} output markers, {whole} well-formed blocks "
                       "(<!-- output: NAME -->, a fenced block, <!-- end output -->)")
    return out


def masked(text: str) -> str:
    """The text as compared: volatile figures masked, trailing blanks and blank end lines dropped."""
    for pattern in VOLATILE:
        text = pattern.sub("<volatile>", text)
    return "\n".join(line.rstrip() for line in text.strip("\n").splitlines())


def differences(quoted: str, produced: str) -> list[str]:
    """The lines where a quoted output and the command's differ (after ``masked``), as
    'line N: quoted | printed'; numbers are compared as printed, so to their printed precision."""
    a, b = masked(quoted).splitlines(), masked(produced).splitlines()
    out = [f"line {i + 1}: {x!r} | {y!r}" for i, (x, y) in enumerate(zip(a, b)) if x.split() != y.split()]
    if len(a) != len(b):
        out.append(f"{len(a)} lines quoted, {len(b)} printed")
    return out


def regenerate(names: set[str] | None = None, check: bool = False) -> list[str]:
    """Run each recipe once for all its blocks; write the blocks (or, with ``check``, list the
    differences). Returns the problems found: an unknown recipe, a block that differs."""
    problems = unmatched()
    produced: dict[str, str] = {}
    for block in blocks():
        if block.name not in RECIPES:
            problems.append(f"{block.path.relative_to(ROOT)}: no recipe named {block.name!r} (docs/regenerate.py)")
            continue
        if names is not None and block.name not in names:
            continue
        if block.name not in produced:
            produced[block.name] = RECIPES[block.name].text()
        where = f"{block.path.relative_to(ROOT)}, block {block.name}"
        problems += [f"{where}: {d}" for d in differences(block.body, produced[block.name])]
    if not check:
        for path in DOCS:
            text = path.read_text(encoding="utf-8")
            new = BLOCK.sub(lambda m: m.group("open") + produced.get(m.group("name"), m.group("body"))
                            + m.group("close"), text)
            if new != text:
                path.write_text(new, encoding="utf-8")
                print(f"wrote {path.relative_to(ROOT)}")
        problems = [p for p in problems if "no recipe" in p or "markers" in p]
    return problems


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("names", nargs="*", help=f"recipes to run (default: all): {', '.join(RECIPES)}")
    parser.add_argument("--check", action="store_true", help="change nothing; exit 1 when a quoted output differs")
    args = parser.parse_args(argv)
    problems = regenerate(set(args.names) or None, check=args.check)
    for p in problems:
        print(p, file=sys.stderr)
    return 1 if problems else 0


if __name__ == "__main__":
    raise SystemExit(main())
