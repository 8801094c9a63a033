"""labsim run --json and labsim sweep: the grid, rows, the comparison, faults, executors."""
from __future__ import annotations

import csv
import json
import math
import re
import sys
from pathlib import Path

import pytest
from helpers import BEHAVIOURS, CLUSTERS, DOCS, FIXTURES, local_cluster

from labsim.foundation.diagnostics import LabsimError
from labsim.runtime.cli.main import main
from labsim.runtime.summary_json import SCHEMA_VERSION, decode_number, number
from labsim.runtime.sweep import driver as sweep_driver
from labsim.runtime.sweep.grid import INTERRUPTED, OK, Row, Task, parse_seeds, parse_setting, run_task
from labsim.runtime.sweep.stats import describe, welch

LAB = str(BEHAVIOURS / "wall_follow.yaml")
SHORT = ["--set", "minutes=0.5"]  # 600 ticks: a few hundredths of a second a run
VARIES = {"wall_time_s", "real_time_factor"}  # the only figures that differ between two runs of a task


def cli(capsys, *args: str) -> tuple[int, str, str]:
    try:
        code = main(list(args))
    except SystemExit as e:  # argparse's own refusal of an option's value
        code = int(e.code or 0)
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    return code, out, err


def same(summary: dict) -> dict:
    return {k: v for k, v in summary.items() if k not in VARIES}


# -- labsim run --json ------------------------------------------------------------------------

def test_run_json_has_every_figure_of_the_summary(capsys) -> None:
    code, out, err = cli(capsys, "run", LAB, *SHORT, "--seed", "3", "--json")
    assert code == 0
    s = json.loads(out)  # only JSON on standard output
    assert (s["schema"], s["version"]) == ("labsim-summary", SCHEMA_VERSION)
    assert s["ticks"] == 600 and s["sim_time_s"] == 30.0 and s["stop_reason"] == "stop condition"
    assert s["seed"] == 3 and s["params"]["minutes"] == 0.5 and s["overridden"] == ["minutes"]
    assert len(s["behaviour"]["sha256"]) == 64 and s["world"] == "walls_lab4" and s["trace"] is None
    robot = s["robots"]["pioneer"]
    assert set(robot) >= {"contacts", "contact_time_s", "clamped_ticks", "wheel_limit_rad_s", "metrics"}
    assert set(robot["metrics"]) == {"near_misses", "overshoot", "following", "smoothness", "closest"}
    assert s["metrics"]["near_misses"] == "count"
    assert sum(r["ticks"] for r in s["rules"]) + s["idle_ticks"] == 600
    assert "follow:3" in s["never_fired"] or all(r["ticks"] for r in s["rules"])
    assert s["faults"] == [] and isinstance(s["warnings"], list)


def test_run_json_to_a_file_keeps_the_text_summary(capsys, tmp_path: Path) -> None:
    path = tmp_path / "s.json"
    code, out, _ = cli(capsys, "run", LAB, *SHORT, "--json", str(path), "--trace", str(tmp_path / "t.csv"))
    assert code == 0 and "done: 600 ticks" in out
    s = json.loads(path.read_text())
    assert s["trace"] == str(tmp_path / "t.csv")


def test_non_finite_numbers_are_strings_in_json() -> None:
    assert [number(math.inf), number(-math.inf), number(math.nan), number(1.5)] == ["inf", "-inf", "nan", 1.5]
    assert decode_number("inf") == math.inf and math.isnan(decode_number("nan"))


# -- the grid ---------------------------------------------------------------------------------

def test_settings_and_seeds_parse() -> None:
    assert parse_setting("front=0.5,1.0").values == ("0.5", "1.0")
    assert parse_setting("front=0.5:1.0:0.25").values == ("0.5", "0.75", "1")
    assert parse_setting("front = 0.1:0.3:0.1").values == ("0.1", "0.2", "0.3")
    assert parse_seeds("1-3,7,2") == (1, 2, 3, 7)
    for bad in ("front", "front=", "front=1:2", "front=2:1:0.5", "front=0:1:0", "front=1,,2"):
        with pytest.raises(LabsimError):
            parse_setting(bad)
    for bad in ("a", "3-1", "-1", "1-x"):
        with pytest.raises(LabsimError):
            parse_seeds(bad)


@pytest.mark.parametrize("args, message", [
    (["--set", "fron=0.5,1.0"], "unknown parameter 'fron' (did you mean 'front'?)"),
    (["--set", "front=0.5,far"], "parameter 'front' is a finite number"),
    (["--set", "front=1", "--set", "front=2"], "this parameter is set twice"),
    (["--seeds", "5-1"], "is not a range of seeds"),
    (["-j", "0"], "-j: error: give 1 or more processes"),
    (["--timeout-per-run", "0"], "argument --timeout-per-run: give from 0.01 to 86400 seconds (a day), not 0"),
    (["--timeout-per-run", "1e308"], "give from 0.01 to 86400 seconds (a day), not 1e308"),
    (["--executor", "dask"], "needs --scheduler tcp://HOST:8786"),
    (["--scheduler", "tcp://x:1"], "only --executor dask takes a scheduler"),
    (["-o", "/no/such/dir/r.csv"], "folder '/no/such/dir' does not exist"),
    (["--traces", "/no/such/dir"], "no such folder"),
    (["--plot", "c.txt"], "give a .png, .svg or .pdf file"),
])
def test_sweep_mistakes_exit_2_before_anything_runs(capsys, tmp_path: Path, args: list[str], message: str) -> None:
    out_csv = tmp_path / "r.csv"
    code, out, err = cli(capsys, "sweep", LAB, *args, *(["-o", str(out_csv)] if "-o" not in args else []))
    assert code == 2 and message in err
    assert not out_csv.exists()


def test_an_unknown_parameter_lists_the_files_parameters(capsys) -> None:
    code, _, err = cli(capsys, "sweep", LAB, "--set", "speed=1,2")
    assert code == 2
    assert "--set speed=1 (in " in err and "parameters of" in err and "minutes, front, side, cruise" in err


# -- the local executor -----------------------------------------------------------------------

@pytest.mark.slow
def test_a_row_equals_the_runs_json_whatever_j(capsys, tmp_path: Path) -> None:
    rows = {}
    for jobs in ("1", "2"):
        path = tmp_path / f"j{jobs}.json"
        code, out, _ = cli(capsys, "sweep", LAB, "--set", "front=0.5,1.0", *SHORT, "--seeds", "1-2",
                           "-j", jobs, "--json", str(path))
        assert code == 0 and "4 runs: 4 ok" in out
        rows[jobs] = json.loads(path.read_text())["rows"]
    assert [same(r["summary"]) for r in rows["1"]] == [same(r["summary"]) for r in rows["2"]]
    row = rows["2"][3]
    assert (row["settings"], row["seed"], row["status"]) == ({"front": "1.0", "minutes": "0.5"}, 2, OK)
    code, out, _ = cli(capsys, "run", LAB, "--set", "front=1.0", *SHORT, "--seed", "2", "--json")
    assert same(json.loads(out)) == same(row["summary"])


@pytest.mark.slow
def test_a_setting_the_sweep_gives_names_its_rows_and_only_none_is_as_in_the_file(capsys) -> None:
    code, out, _ = cli(capsys, "sweep", LAB, "--set", "minutes=0.1", "--seeds", "1-2", "-j", "1", "--no-progress")
    assert code == 0 and "(as in the file)" not in out
    assert ("near_misses  (count; lower is better)\n  setting      n  mean  sd  95% CI  min  max\n"
            "  minutes=0.1  2 ") in out
    code, out, _ = cli(capsys, "sweep", LAB, "--set", "minutes=0.1", "--set", "front=0.5,1", "--seeds", "1",
                       "-j", "1", "--no-progress")
    assert code == 0 and "\n  front=0.5  1 " in out and "minutes=0.1  1" not in out  # the varying one names them
    code, out, _ = cli(capsys, "sweep", str(Path(LAB).with_name("wall_follow_handout.yaml")), "--seeds", "1",
                       "-j", "1", "--no-progress")
    assert code == 0 and "\n  (as in the file)  1 " in out


def test_the_table_compares_two_settings(capsys, tmp_path: Path) -> None:
    out_csv = tmp_path / "r.csv"
    code, out, _ = cli(capsys, "sweep", LAB, "--set", "front=0.5,1.0", *SHORT, "--seeds", "1-3", "-j", "2",
                       "-o", str(out_csv), "--maximize", "following")
    assert code == 0
    assert "near_misses  (count; lower is better)" in out and "following  (duration; higher is better)" in out
    assert "setting    n" in out and "95% CI" in out and "best" in out
    assert "front=1.0 vs front=0.5:" in out and "Welch's t-test" in out
    with open(out_csv, newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 6 and rows[0]["front"] == "0.5" and rows[5]["seed"] == "3"
    assert set(rows[0]) >= {"status", "message", "ticks", "wall_time_s", "contacts", "near_misses", "closest"}


@pytest.mark.slow
def test_a_batch_with_broken_files_completes_with_them_marked(capsys, tmp_path: Path, write) -> None:
    crowded = write((FIXTURES / "minimal.yaml").read_text().replace(
        "pioneer: {model: pioneer_p3dx, at: [0, 0, 0]}", "pioneer: {model: pioneer_p3dx, count: 100, at: random}"),
        "crowded.yaml")
    files = [LAB, str(FIXTURES / "structure_with_error.yaml"), str(FIXTURES / "unknown_sensor_with_error.yaml"),
             str(tmp_path / "missing.yaml"), str(crowded)]
    out_csv = tmp_path / "r.csv"
    code, out, _ = cli(capsys, "sweep", *files, *SHORT[:0], "-j", "2", "-o", str(out_csv), "--set", "front=0.5")
    assert code == 1
    with open(out_csv, newline="") as f:
        rows = {Path(r["file"]).name: r for r in csv.DictReader(f)}
    assert rows["wall_follow.yaml"]["status"] == "ok"
    assert rows["structure_with_error.yaml"]["status"] == "compile error"
    assert rows["structure_with_error.yaml"]["message"].endswith("structure_with_error.yaml: error: missing "
                                                                 "required key 'rules:'")  # the first, as check says
    assert "unknown_sensor_with_error.yaml:13:8: error: unknown name 'sonr5'" in rows[
        "unknown_sensor_with_error.yaml"]["message"]
    assert rows["missing.yaml"]["message"].endswith("error: no such behaviour file")
    assert rows["crowded.yaml"]["status"] == "compile error"  # robots are placed when it compiles
    assert "no free place left in world 'walls_lab4' for robot 'pioneer[" in rows["crowded.yaml"]["message"]
    assert "5 runs: 1 ok, 4 compile error" in out


@pytest.mark.slow
def test_a_run_past_its_time_is_killed_and_the_pool_goes_on(capsys, tmp_path: Path, write) -> None:
    slow = write((FIXTURES / "minimal.yaml").read_text().replace("stop: time >= 1", "stop: time >= 1e9"), "slow.yaml")
    out_csv = tmp_path / "r.csv"
    code, out, _ = cli(capsys, "sweep", str(slow), str(FIXTURES / "minimal.yaml"), "--seeds", "1-2", "-j", "1",
                       "--timeout-per-run", "1.5", "--budget", "ticks=1000000000", "-o", str(out_csv))
    assert code == 1
    with open(out_csv, newline="") as f:
        statuses = [(Path(r["file"]).name, r["status"]) for r in csv.DictReader(f)]
    assert statuses == [("slow.yaml", "timeout")] * 2 + [("minimal.yaml", "ok")] * 2


def test_a_deadline_stops_a_run_from_inside_its_loop(write) -> None:
    """What a Dask worker does instead of killing: the run is stopped between ticks."""
    slow = write((FIXTURES / "minimal.yaml").read_text().replace("stop: time >= 1", "stop: time >= 1e9"), "slow.yaml")
    result = run_task(Task(0, str(slow), (), 1), deadline_s=0.3)
    assert result["status"] == "timeout" and result["message"].startswith("stopped after 0.3 s at tick ")
    assert run_task(Task(0, str(FIXTURES / "minimal.yaml"), (("front", "0.4"),), 1), deadline_s=60)["status"] == OK


def test_sweep_json_to_standard_output(capsys) -> None:
    code, out, err = cli(capsys, "sweep", LAB, *SHORT, "--seeds", "1-2", "-j", "1", "--json", "-")
    data = json.loads(out)
    assert code == 0 and (data["schema"], data["version"], data["seeds"]) == ("labsim-sweep", 1, [1, 2])
    assert [r["status"] for r in data["rows"]] == [OK, OK] and "2 runs: 2 ok" in err


def test_ctrl_c_writes_the_rows_done_so_far(capsys, tmp_path: Path, monkeypatch) -> None:
    class Stopped:
        def __init__(self) -> None:
            self.in_flight: dict[int, Task] = {}

        def results(self, tasks: list[Task]):
            yield Row(tasks[0], OK, result=None)
            self.in_flight = {1: tasks[1]}
            raise KeyboardInterrupt

        def interrupt(self, why: str) -> list[Row]:
            return [Row(t, INTERRUPTED, f"stopped by {why}") for t in self.in_flight.values()]

    monkeypatch.setattr(sweep_driver, "_executor", lambda o, info: Stopped())
    out_csv = tmp_path / "r.csv"
    code, out, _ = cli(capsys, "sweep", LAB, "--seeds", "1-5", "-o", str(out_csv))
    assert code == 130 and "interrupted: 2 runs: 1 ok, 1 interrupted (of 5)" in out
    with open(out_csv, newline="") as f:
        assert [r["status"] for r in csv.DictReader(f)] == [OK, INTERRUPTED]


def test_the_progress_bar_counts_runs_and_failures() -> None:
    import io

    from labsim.runtime.sweep.output import SweepProgress

    stream = io.StringIO()
    bar = SweepProgress(4, stream)
    task = Task(0, "f.yaml", (), 1)
    bar.update(Row(task, OK))
    bar.update(Row(task, "timeout", "killed"))
    assert "2/4 runs, 1 failed, ETA " in stream.getvalue()
    bar.clear()
    assert stream.getvalue().endswith("\r")


# -- the comparison ---------------------------------------------------------------------------

def test_describe_gives_a_t_interval() -> None:
    s = describe([1.0, 2.0, 3.0, math.inf])
    assert (s.n, s.mean, s.sd, s.min, s.max, s.left_out) == (3, 2.0, 1.0, 1.0, 3.0, 1)
    assert s.ci_high - 2.0 == pytest.approx(4.302653 / math.sqrt(3), rel=1e-6)  # t(0.975, 2) = 4.3027
    assert math.isnan(describe([5.0]).sd) and describe([]).n == 0


def test_welch_says_whether_a_difference_beats_the_noise() -> None:
    assert welch("f", "m", "a", "b", [1, 2, 3, 2, 1], [9, 8, 9, 10, 9]).verdict == "larger than the seeds' noise"
    assert welch("f", "m", "a", "b", [1, 2, 3, 2, 1], [2, 1, 3, 2, 2]).verdict == "within the seeds' noise"
    assert welch("f", "m", "a", "b", [1], [2, 3]).verdict.startswith("too few runs")
    assert welch("f", "m", "a", "b", [0, 0], [0, 0]).verdict == "the same in every run"


def test_the_best_is_the_highest_mean_of_a_metric_better_higher(capsys, tmp_path: Path) -> None:
    """The wall lab's following (declared better: higher) and closest (a minimum: higher by default)
    mark their highest mean; near_misses (a count) its lowest. No --maximize."""
    path = tmp_path / "s.json"
    code, out, _ = cli(capsys, "sweep", LAB, "--set", "front=0.5,1.0", *SHORT, "--seeds", "1-2", "-j", "2",
                       "--json", str(path))
    assert code == 0
    assert "following  (duration; higher is better)" in out and "closest  (minimum; higher is better)" in out
    assert "near_misses  (count; lower is better)" in out
    table = json.loads(path.read_text())["comparison"]
    for metric, better, pick in (("following", "higher", max), ("closest", "higher", max),
                                 ("near_misses", "lower", min), ("overshoot", "lower", min)):
        entries = [e for e in table if e["metric"] == metric]
        assert {e["better"] for e in entries} == {better}
        top = pick(e["mean"] for e in entries)  # settings tied at the best mean are each marked best
        assert [e["settings"] for e in entries if e["best"]] == [e["settings"] for e in entries if e["mean"] == top]
        block = out.split(f"{metric}  (")[1].split("\n\n")[0]
        best_line = next(line for line in block.splitlines() if line.endswith(f"best ({better})"))
        assert best_line.split()[0] in {e["settings"].split()[0] for e in entries if e["mean"] == top}


SPIN = ("labsim: 1\nworld: walls_lab4\nstop: time >= 1\nrobots:\n  p: {model: pioneer_p3dx, at: [0, 0, 0]}\n"
        "params:\n  speed: 1\nrules:\n  - always move(speed)\n")


def test_a_duration_that_declares_no_direction_marks_no_best(capsys, tmp_path: Path, write) -> None:
    path = write(SPIN + "metrics:\n  moving: duration(speed > 1.5)\n  hits: count(sonar5 < 0.5)\n")
    out_json = tmp_path / "s.json"
    code, out, _ = cli(capsys, "sweep", str(path), "--set", "speed=1,2", "-j", "1", "--json", str(out_json))
    assert code == 0
    block = out.split("moving  (")[1].split("\n\n")[0]
    assert block.splitlines()[0] == "duration; declares no direction)"
    assert "best" not in block.replace("no best marked", "")
    assert ("  no best marked: to mark one, say which way is better in the file, moving: {value: ..., "
            "better: higher} (or lower), or pass --maximize moving") in block.splitlines()
    moving = [e for e in json.loads(out_json.read_text())["comparison"] if e["metric"] == "moving"]
    assert [(e["best"], e["better"]) for e in moving] == [(False, None), (False, None)]
    code, out, _ = cli(capsys, "sweep", str(path), "--set", "speed=1,2", "-j", "1", "--maximize", "moving")
    assert "moving  (duration; higher is better)" in out and "no best marked" not in out


def test_files_that_disagree_on_a_direction_mark_no_best(capsys, write) -> None:
    a = write(SPIN + "metrics:\n  moving: {value: duration(speed > 0.5), better: higher}\n", "a.yaml")
    b = write(SPIN.replace("speed: 1", "speed: 0") + "metrics:\n  moving: {value: duration(speed > 0.5), "
                                                       "better: lower}\n", "b.yaml")
    code, out, _ = cli(capsys, "sweep", str(a), str(b), "-j", "1")
    assert code == 0 and "moving  (duration; the files say different ways are better)" in out
    assert "best (" not in out
    assert "  no best marked: give 'moving' the same 'better:' in every file, or pass --maximize moving" in out


@pytest.mark.slow
def test_plot_draws_a_chart(capsys, tmp_path: Path) -> None:
    pytest.importorskip("matplotlib")
    png = tmp_path / "c.png"
    code, out, _ = cli(capsys, "sweep", LAB, "--set", "front=0.5,1.0", *SHORT, "--seeds", "1-2", "--plot", str(png))
    assert code == 0 and png.read_bytes()[:4] == b"\x89PNG" and png.stat().st_size > 10_000


def test_a_sweep_over_a_noise_parameter(capsys, tmp_path: Path) -> None:
    """docs/language.md's example of noise numbers as parameters (format 1.2), swept over its dropout."""
    (text,) = re.findall(r"```yaml\n(# noise example: noisy_sweep\n.*?)```", (DOCS / "language.md").read_text(), re.S)
    path = tmp_path / "noisy_sweep.yaml"
    path.write_text(text)
    out = tmp_path / "sweep.json"
    code, printed, _ = cli(capsys, "sweep", str(path), "--set", "drop=0,0.5,1", "--set", "minutes=0.2", "-j", "1",
                           "--json", str(out))
    assert code == 0 and "3 runs: 3 ok" in printed
    rows = {r["settings"]["drop"]: r["summary"]["robots"]["pioneer"] for r in json.loads(out.read_text())["rows"]}
    assert rows["0"]["noise"] == {"sonar": {"std_m": 0.02}} and rows["0"]["sonar_readings_lost"] == 0
    assert rows["1"]["noise"] == {"sonar": {"std_m": 0.02, "dropout": 1.0}}
    assert 0 < rows["0.5"]["sonar_readings_lost"] < rows["1"]["sonar_readings_lost"]
    assert rows["0"]["contact_time_s"] < rows["1"]["contact_time_s"]  # blind, it stays against the wall longer
    # a value out of the key's range is that run's compile error, naming the --set
    code, printed, _ = cli(capsys, "sweep", str(path), "--set", "drop=0,2", "--set", "minutes=0.05", "-j", "1",
                           "--json", str(out))
    bad = [r for r in json.loads(out.read_text())["rows"] if r["settings"]["drop"] == "2"]
    assert bad[0]["status"] == "compile error"
    assert ("sonar noise dropout must be between 0 and 1, not 2 (parameter 'drop', from --set drop=2)"
            in bad[0]["message"])


# -- the Dask executor ------------------------------------------------------------------------

@pytest.fixture(scope="module", params=CLUSTERS)
def any_cluster(request):
    """A Dask cluster on this machine: in threads (quick), and in processes (-m long)."""
    with local_cluster(request.param) as c:
        yield c


@pytest.fixture(scope="module")
def cluster():
    """A Dask cluster of two worker processes on this machine, one of which a test kills."""
    with local_cluster() as c:
        yield c


def test_dask_gives_the_same_rows_as_local(capsys, tmp_path: Path, any_cluster) -> None:
    """Also a world file beside the behaviour, which travels with the task, and a broken file."""
    (tmp_path / "worlds").mkdir()
    (tmp_path / "labs").mkdir()
    world = BEHAVIOURS.parent / "backends" / "scene" / "worlds" / "walls_lab4.yaml"
    (tmp_path / "worlds" / "room.yaml").write_text(world.read_text())
    own = tmp_path / "labs" / "own.yaml"
    own.write_text(Path(LAB).read_text().replace("world: walls_lab4", "world: ../worlds/room.yaml"))
    files = [LAB, str(own), str(FIXTURES / "structure_with_error.yaml")]
    results = {}
    for executor in ("local", "dask"):
        path = tmp_path / f"{executor}.json"
        extra = (["--executor", "dask", "--scheduler", any_cluster.scheduler_address] if executor == "dask"
                 else ["-j", "2"])
        code, out, _ = cli(capsys, "sweep", *files, "--set", "front=0.5,1.0", *SHORT, "--seeds", "1-2",
                           "--json", str(path), "--traces", str(tmp_path), *extra,
                           "--allow-path", str(tmp_path / "worlds"))  # own.yaml reads ../worlds
        assert code == 1 and "12 runs: 8 ok, 4 compile error" in out, out[-1500:]
        results[executor] = json.loads(path.read_text())["rows"]
        if executor == "local":
            traces = {p.name: p.read_text() for p in tmp_path.glob("*.csv")}
    local, remote = results["local"], results["dask"]
    assert [(r["status"], r["message"]) for r in local] == [(r["status"], r["message"]) for r in remote]
    assert [r["summary"] and same(r["summary"]) for r in local] == [r["summary"] and same(r["summary"]) for r in remote]
    assert all(r["worker"].startswith(("tcp://", "inproc://")) for r in remote if r["status"] == OK)  # Dask's
    assert remote[4]["summary"]["world"] == "walls_lab4" and remote[4]["file"] == str(own)
    assert {p.name: p.read_text() for p in tmp_path.glob("*.csv")} == traces  # byte for byte


@pytest.mark.slow
@pytest.mark.long
def test_a_lost_dask_worker_s_runs_are_retried(capsys, tmp_path: Path, cluster) -> None:
    import os
    import signal
    import threading
    import time

    from distributed import Client

    def kill_a_busy_worker() -> None:
        with Client(cluster.scheduler_address, set_as_default=False) as client:
            pids = client.run(os.getpid)
            deadline = time.monotonic() + 60
            while time.monotonic() < deadline:
                busy = [w for w, keys in client.processing().items() if keys]
                if busy:
                    time.sleep(0.3)  # into the run
                    os.kill(pids[busy[0]], signal.SIGKILL)
                    return
                time.sleep(0.05)

    killer = threading.Thread(target=kill_a_busy_worker)
    killer.start()
    path = tmp_path / "r.json"
    code, out, _ = cli(capsys, "sweep", LAB, "--set", "minutes=60", "--seeds", "1-4", "--executor", "dask",
                       "--scheduler", cluster.scheduler_address, "--json", str(path))
    killer.join()
    rows = json.loads(path.read_text())["rows"]
    assert code == 0 and [r["status"] for r in rows] == [OK] * 4
    retried = [r for r in rows if r["retries"]]
    assert retried and "retried 1 time(s) after a worker was lost" in retried[0]["message"]
    assert "started again after a Dask worker was lost" in out


def test_workers_are_forked_from_the_sweep_only_while_it_runs_no_other_thread() -> None:
    """A thread holding a lock at a fork would leave the worker's copy held: with another
    thread running, workers come from the fork server as before."""
    import threading

    from labsim.runtime.batch import fork_here

    release = threading.Event()
    other = threading.Thread(target=release.wait)
    other.start()
    try:
        assert not fork_here()
    finally:
        release.set()
        other.join()
    assert fork_here() == (sys.platform.startswith("linux") and threading.active_count() == 1)


SAYS = """labsim: {version}
world: walls_lab4
seed: 5
stop: time >= 1
robots:
  a: {{model: pioneer_p3dx, at: random}}
  b: {{model: pioneer_p3dx, at: random}}
params:
  r: 3
let:
  sx: x
rules:
  - {say}
  - always move(2)
metrics:
  fx: final(sx)
"""


@pytest.mark.parametrize(("version", "say", "name", "values"), [
    ("1.3", "when true then say(p, x, r)", "r", ("-1,2,3", "2,3", "-1,-2")),
    ("1.2", "if x > 100 + r then stop()\n  - if [sonar1, sonar2][r] > 9 then stop()", "r", ("7,1,0", "1,0", "7,8")),
])
def test_every_row_of_a_sweep_runs_with_the_file_s_seed_whatever_setting_fails(
        capsys, tmp_path: Path, write, version: str, say: str, name: str, values: tuple[str, ...]) -> None:
    """A first value that does not compile fails its own rows; the others run, with the file's seed 5."""
    path = write(SAYS.format(version=version, say=say))
    found = []
    for i, given in enumerate(values):
        out_csv = tmp_path / f"r{i}.csv"
        cli(capsys, "sweep", str(path), "--set", f"{name}={given}", "-j", "1", "-o", str(out_csv))
        with open(out_csv, newline="") as f:
            found.append([(r[name], r["seed"], r["status"], r.get("fx", "")) for r in csv.DictReader(f)])
    first, second = values[1].split(",")
    assert {row[1] for rows in found for row in rows} == {"5"}
    assert found[0][0] == (values[0].split(",")[0], "5", "compile error", "")
    assert found[0][1:] == found[1]  # the rows that compile are the same, the failing value first or not
    assert [row[:3] for row in found[1]] == [(first, "5", "ok"), (second, "5", "ok")]
    assert [row[2] for row in found[2]] == ["compile error", "compile error"]  # none compiles: the file's seed too
