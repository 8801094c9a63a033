"""Breakpoints: the condition a view pauses on, and ``labsim run --break COND``, which stops there.

One compiler (``labsim.dsl.watch``) for both, evaluated by the reference evaluator, which knows
groups: ``min([sonar5, sonar2]) < 0.5`` pauses, as ``min(sonar5, sonar2) < 0.5`` does, on the
same tick of the wall lab.
"""
from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import pytest

from labsim.dsl.analysis.evaluate import Members, log_text
from labsim.dsl.compile import compile_file
from labsim.dsl.syntax.parse import parse_expr, parse_rule
from labsim.dsl.watch import compile_watch
from labsim.foundation.diagnostics import LabsimError

ROOT = Path(__file__).resolve().parents[2]
WALL = ROOT / "behaviours" / "wall_follow.yaml"


def run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "labsim", "run", str(WALL), "--set", "minutes=0.4", *args],
                          capture_output=True, text=True, timeout=300)


def test_a_group_in_a_breakpoint_stops_on_the_tick_its_members_written_out_do() -> None:
    outputs = [run("--break", when) for when in ("min([sonar5, sonar2]) < 0.5", "min(sonar5, sonar2) < 0.5",
                                                  "min([sonar5, sonar5] - [0, 0]) < 0.5 or [sonar2][0] < 0.5")]
    for proc in outputs:
        assert proc.returncode == 0, proc.stderr
    heads = [proc.stdout.splitlines()[0] for proc in outputs]
    assert heads[0] == "--break: 'min([sonar5, sonar2]) < 0.5' held at tick 367 (18.35 s) for robot pioneer"
    assert heads[1] == "--break: 'min(sonar5, sonar2) < 0.5' held at tick 367 (18.35 s) for robot pioneer"
    assert heads[2].endswith("held at tick 367 (18.35 s) for robot pioneer")
    assert outputs[0].stdout.splitlines()[1:] == ["  state: wander", "  rule: wander:1", "  sonar5 = 0.498539",
                                                  "  sonar2 = 0.62237"]
    assert "collisions" not in outputs[0].stdout  # the summary of a run cut short is not printed


def test_a_breakpoint_that_never_holds_says_so_and_the_summary_follows() -> None:
    proc = run("--break", "sonar5 < 0 or state == follow and time > 100")
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert lines[0] == ("--break: 'sonar5 < 0 or state == follow and time > 100' never held on ticks 0 to 480 "
                        "(0.00 s to 24.00 s), where the run ended")
    assert lines[1].startswith("Wall following with sonars")
    assert "done: 480 ticks, 24.00 s simulated" in lines[2] and "stopped at tick 480 (24.00 s)" in lines[2]


@pytest.mark.parametrize("when", ["time >= 24", "tick == 480"])
def test_a_breakpoint_sees_the_stopping_tick_the_trace_has_a_row_for(when: str, tmp_path: Path) -> None:
    trace = tmp_path / "t.csv"
    proc = run("--break", when, "--trace", str(trace))
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.splitlines()[:3] == [f"--break: '{when}' held at tick 480 (24.00 s) for robot pioneer",
                                            "  state: follow",
                                            "  rule: none (the run's stop condition held on this tick: no rule "
                                            "acts on it)"]
    rows = [line for line in trace.read_text().splitlines() if line and not line.startswith("#")]
    assert rows[-1].startswith("480,24,")


@pytest.mark.parametrize(("when", "message"), [
    ("max([prev(sonar5, 0), 0]) > 0.5", "--break:1:6: prev() remembers earlier ticks; a breakpoint sees one tick "
                                        "at a time"),
    ("sonr5 < 1", "--break:1:1: unknown name 'sonr5' (did you mean 'sonar5'?)"),
    ("[sonar5, sonar2][2] < 1", "--break:1:18: this group has 2 members, at places 0 to 1; not 2"),
    ("min(sonar5, sonar2)", "--break:1:1: a breakpoint's condition must be a boolean, but this is a number"),
    ("collided", "--break:1:1: 'collided' is a sensor this behaviour does not read: a breakpoint sees what the "
                 "behaviour reads"),
    ("bogus:1", "--break:1:6: unexpected ':' in an expression"),
    ("any(sonar1..sonar8 < 0.5)", "--break:1:5: sonar1..sonar8 names sonar1, sonar3, sonar4, sonar6, sonar7, which "
                                  "this behaviour does not read: a breakpoint sees what the behaviour reads"),
])
def test_a_breakpoint_is_checked_as_the_file_is(when: str, message: str) -> None:
    program = compile_file(WALL)
    with pytest.raises(LabsimError) as e:
        compile_watch(program, when)
    [d] = e.value.diagnostics
    assert f"{d.path}:{d.line}:{d.col}: {d.message}" == message


def test_the_view_s_breakpoint_with_a_group_holds_on_its_members() -> None:
    program = compile_file(WALL)
    watch = compile_watch(program, "min([sonar5, sonar2]) < 0.5 and count(sonar8..sonar9 < 1) >= 1")
    readings = [math.inf] * len(program.channels)
    slots = [0.0] * program.slot_count
    at = {name: i for i, name in enumerate(program.channels)}
    readings[at["sonar5"]], readings[at["sonar2"]] = 0.7, 0.4
    assert not watch.holds(3, 0.05, readings, slots)  # neither sonar8 nor sonar9 is under 1
    readings[at["sonar9"]] = 0.9
    assert watch.holds(3, 0.05, readings, slots)
    assert watch.values(3, 0.05, readings, slots)[:2] == [("sonar5", 0.7), ("sonar2", 0.4)]
    assert watch.reads == ("sonar5", "sonar2", "sonar8", "sonar9")


def test_break_and_json_are_refused_together() -> None:
    proc = run("--break", "sonar5 < 1", "--json")
    assert proc.returncode == 2
    assert proc.stderr.strip() == ("--break: error: a run stopped at a breakpoint has no summary to write as JSON: "
                                   "leave out --json or --break")


def test_the_state_a_breakpoint_reads_is_shown_by_its_name() -> None:
    proc = run("--break", "ahead < front and state == wander")
    assert proc.stdout.splitlines() == [
        "--break: 'ahead < front and state == wander' held at tick 367 (18.35 s) for robot pioneer",
        "  state: wander", "  rule: wander:1", "  ahead = 0.498539", "  front = 0.5", "  state = wander"]


def test_the_evaluator_writes_a_when_rule_s_log_as_the_run_prints_it(write) -> None:
    """A log's fields (a group's member, a reduction, a function over a group, text chosen by a
    condition, a whole-number field of a fraction) by the reference evaluator and by the run, from
    the readings of that tick in the trace."""
    text = ("log(\"{front[1]:.2f} {argmin(front)} {near(front, 0.6):d} {'near' if min(front) < 0.5 else 'far'} "
            "{time:d}\")")
    path = write("labsim: 1.2\nworld: walls_lab4\nstop: time >= 1\nrobots:\n  p: {model: pioneer_p3dx, "
                 "at: [6.8, 0.3, 10]}\nfunctions:\n  near(g, d): count(g < d)\n"
                 "let:\n  front: [sonar4, sonar5, sonar6]\n"
                 f"rules:\n  - when tick == 3 then {text}\n  - always move(1)\n")
    trace = path.with_suffix(".csv")
    proc = subprocess.run([sys.executable, "-m", "labsim", "run", str(path), "-q", "--trace", str(trace)],
                          capture_output=True, text=True, timeout=120)
    [printed] = [line.split(": ", 1)[1] for line in proc.stderr.replace("\r", "").splitlines() if line.strip()]
    rows = [line.split(",") for line in trace.read_text().splitlines() if not line.startswith("#")]
    head, row = rows[0], rows[4]  # tick 3
    front = Members(float(row[head.index(n)]) for n in ("sonar4", "sonar5", "sonar6"))
    action = parse_rule(f"always {text}").actions[0]
    assert action.text is not None
    shown, faults = log_text(action.text, {"tick": 3.0, "time": 3 * 0.05, "dt": 0.05, "front": front},
                             functions={"near": (("g", "d"), parse_expr("count(g < d)"))})
    assert (shown, faults) == (printed, ())
    assert printed == "0.42 1.0 3 near 0.15"  # facing the east wall, 0.4 m off


def test_the_evaluator_keeps_the_memory_of_built_ins_between_ticks() -> None:
    """prev, rising (primed from 1.2 on) and counter, one closure per call site, as generated code keeps them."""
    from labsim.dsl.analysis.evaluate import Memory, evaluate
    memory = Memory(dt_s=0.05, version=1.2)
    e = parse_expr("[prev(x, -1), rising(x > 1), counter(x > 1)]")
    seen = [evaluate(e, {"x": x}, memory=memory)[0] for x in (2.0, 0.0, 3.0, 4.0, 0.5, 5.0)]
    assert seen == [(-1.0, False, 0.0), (2.0, False, 0.0), (0.0, True, 1.0), (3.0, False, 1.0),
                    (4.0, False, 1.0), (0.5, True, 2.0)]
    with pytest.raises(Exception, match="remembers earlier ticks"):
        evaluate(e, {"x": 1.0})  # no memory: one tick cannot answer


GROUPS = """labsim: 1.2
world: walls_lab4
stop: time >= 3
robots: {pioneer: {model: pioneer_p3dx, at: [0, 0, 0]}}
functions:
  nearer(a, b): min(a, b)
let:
  front: sonar1..sonar8
  pair: [sonar4 - 0.1, sonar5 - 0.1]
  n: nearer(sonar4, sonar5)
metrics:
  near_misses: count(n < 0.3)
rules:
  - if min(front) < 0.5 or pair[0] < 0.2 then arc(1, -1)
  - else move(2)
"""


def test_a_breakpoint_reads_group_signals_and_the_file_s_functions(write) -> None:
    path = write(GROUPS)
    proc = subprocess.run([sys.executable, "-m", "labsim", "run", str(path), "--break",
                           "time > 1 and min(front) > 0 and pair[1] > 0 and nearer(sonar4, sonar5) > 0"],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.splitlines()[:8] == [
        "--break: 'time > 1 and min(front) > 0 and pair[1] > 0 and nearer(sonar4, sonar5) > 0' held at tick 21 "
        "(1.05 s) for robot pioneer",
        "  state: main", "  rule: main:2", "  time   = 1.05", "  front  = [inf, inf, inf, inf, inf, inf, inf, inf]",
        "  pair   = [inf, inf]", "  sonar4 = inf", "  sonar5 = inf"]


@pytest.mark.parametrize(("when", "message", "notes"), [
    ("near_misses > 0", "--break:1:1: 'near_misses' is a metric: metrics are summed up over the run for the summary, "
                        "and expressions cannot read them",
     ("to use it here, compute it as a signal under 'let:' (e.g. 'held(...)' for a duration, 'counter(...)' for a "
      "count, 'total(...)' for a sum; docs/language.md, Time and memory)",)),
    ("nearer(front, 1) < 0.5", "{path}:6:21: argument 1 of min() must be a number, but this is a group of numbers",
     ("a group holds one value per member: take min(...), max(...), mean(...), sum(...), argmin(...) or argmax(...) "
      "of it, or one member, as in front[0]", "applying min() to each member of a group is format 1.3: start the "
      "file with 'labsim: 1.3'", "in the call of nearer() at --break:1:1")),
    ("pair[2] < 0.5", "--break:1:6: this group has 2 members, at places 0 to 1; not 2",
     ("places count from 0: the first member is [0]",)),
])
def test_a_breakpoint_s_mistake_with_a_group_function_or_metric_says_what_it_is(
        write, when: str, message: str, notes: tuple[str, ...]) -> None:
    path = write(GROUPS)
    with pytest.raises(LabsimError) as e:
        compile_watch(compile_file(path), when)
    [d] = e.value.diagnostics
    assert (f"{d.path}:{d.line}:{d.col}: {d.message}", d.notes) == (message.replace("{path}", str(path)), notes)


def test_a_group_a_breakpoint_cannot_read_says_which_name_it_cannot_see(write) -> None:
    path = write(GROUPS.replace("  n: nearer", "  back: sonar9..sonar16\n  who: [index, 1]\n  n: nearer")
                 .replace("else move(2)", "if min(back) < who[0] then move(1)\n  - else move(2)"))
    program = compile_file(path)
    assert compile_watch(program, "min(back) < 0.5").reads == ("back",)
    with pytest.raises(LabsimError) as e:
        compile_watch(program, "who[1] < 0.5")
    [d] = e.value.diagnostics
    assert (d.line, d.col, d.message) == (1, 1, "'who' is a group signal a breakpoint cannot read: it names 'index', "
                                                "which a breakpoint does not see")


def test_a_breakpoint_reads_a_mechanism_s_fields() -> None:
    proc = subprocess.run([sys.executable, "-m", "labsim", "run", str(ROOT / "behaviours" / "crane.yaml"),
                           "--break", "Load.x > 2"], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.splitlines()[:4] == ["--break: 'Load.x > 2' held at tick 210 (10.50 s) for robot crane",
                                            "  state: (the file has no states)",
                                            "  rule: none (no rule held on this tick)", "  Load.x = 2.03663"]


def test_a_breakpoint_that_does_not_parse_says_it_is_one_condition() -> None:
    with pytest.raises(LabsimError) as e:
        compile_watch(compile_file(WALL), "bogus:1")
    [d] = e.value.diagnostics
    assert d.notes == ("a breakpoint is one condition of the language, as in --break 'sonar5 < 0.5'",)


@pytest.mark.parametrize(("when", "col", "name"), [("mean(lane) > 0.5", 6, "lane"),
                                                   ("mean(gray(camera)) > 0.5", 11, "camera")])
def test_an_image_in_a_breakpoint_is_said_to_be_one(when: str, col: int, name: str) -> None:
    with pytest.raises(LabsimError) as e:
        compile_watch(compile_file(ROOT / "behaviours" / "road_follow.yaml"), when)
    [d] = e.value.diagnostics
    assert (d.line, d.col, d.message, d.notes) == (
        1, col, f"'{name}' is an image: a breakpoint reads numbers and booleans",
        (f"make a number of it a signal of the file (e.g. 'let: seen: mean({name})') and watch the signal",))


RELAY = """labsim: 1.3
world: walls_lab4
seed: 1
stop: time >= 0.5
robots:
  a: {model: pioneer_p3dx, at: [0, 0, 0], params: {role: 0}}
  b: {model: pioneer_p3dx, at: [1, 0, 0], params: {role: 1}}
params:
  role: 0
let:
  h1: heard(ch1, -1)
rules:
  - when role == 0 then say(ch1, tick), say(ch3, 1)
  - when role == 1 then say(ch2, h1)
  - always stop()
"""


def test_a_breakpoint_reads_heard_as_the_file_s_signals_do(write) -> None:
    """heard(ch1) in a breakpoint is the robot's inbox of the tick: b hears a's tick 1 on tick 2, as h1 does."""
    path = write(RELAY)
    for when, head, values in [
        ("heard(ch1) == 1", "'heard(ch1) == 1' held at tick 2 (0.10 s) for robot b", ["  heard(ch1) = 1"]),
        ("heard(ch1, 7) == 7 and role == 0", "'heard(ch1, 7) == 7 and role == 0' held at tick 0 (0.00 s) for robot a",
         ["  heard(ch1) = nan"]),
        ("h1 == 3 and heard(ch1) == h1", "'h1 == 3 and heard(ch1) == h1' held at tick 4 (0.20 s) for robot b",
         ["  h1         = 3", "  heard(ch1) = 3"])]:
        proc = subprocess.run([sys.executable, "-m", "labsim", "run", str(path), "--break", when],
                              capture_output=True, text=True, timeout=300)
        assert proc.returncode == 0, proc.stderr
        assert proc.stdout.splitlines()[0] == "--break: " + head
        assert proc.stdout.splitlines()[3:3 + len(values)] == values


@pytest.mark.parametrize(("when", "message", "notes"), [
    ("heard(zz) == 1", "--break:1:7: nothing says on channel 'zz'", ("channels said in this file: ch1, ch3, ch2",)),
    ("heard(ch1x) == 1", "--break:1:7: nothing says on channel 'ch1x' (did you mean 'ch1'?)",
     ("channels said in this file: ch1, ch3, ch2",)),
    ("1 < heard(ch3)", "--break:1:11: a breakpoint reads what the file hears, and the file never reads heard(ch3)",
     ("read it in a signal of the file (e.g. 'let: got: heard(ch3)') and watch the signal",)),
])
def test_a_breakpoint_refuses_a_channel_the_file_does_not_hear(write, when: str, message: str,
                                                               notes: tuple[str, ...]) -> None:
    with pytest.raises(LabsimError) as e:
        compile_watch(compile_file(write(RELAY)), when)
    assert [(f"{d.path}:{d.line}:{d.col}: {d.message}", d.notes) for d in e.value.diagnostics] == [(message, notes)]
    proc = subprocess.run([sys.executable, "-m", "labsim", "run", str(write(RELAY)), "--break", when],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 2 and message.replace(": ", ": error: ", 1) in proc.stderr


def test_a_breakpoint_s_channel_is_no_name_it_reads_and_index_is_not_readable(write) -> None:
    with pytest.raises(LabsimError) as e:
        compile_watch(compile_file(write(RELAY)), "heard(sonar16) > 0 and index == 1")
    assert [(d.line, d.col, d.message, d.notes) for d in e.value.diagnostics] == [
        (1, 7, "nothing says on channel 'sonar16'", ("channels said in this file: ch1, ch3, ch2",)),
        (1, 24, "'index' (the robot's place in its group) is not readable by a breakpoint",
         ("read it in a signal of the file (e.g. 'let: place: index') and watch the signal",))]
