"""labsim view end to end in a real headless Chromium, driven by Playwright.

Each test starts ``labsim view ... --port 0 --no-browser`` and opens its page. Without a
Chromium (or the ``playwright`` package) the tests skip and say how to install one, except
under CI (``CI=true``), where a missing browser fails. Screenshots are kept as artifacts in
``test-artifacts/`` (or ``$LABSIM_ARTIFACTS``).
"""
from __future__ import annotations

import itertools
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pytest
from helpers import ROOT

from labsim.runtime.trace import read_trace

pytestmark = pytest.mark.slow  # a headless Chromium and a labsim view process per test

ARTIFACTS = Path(os.environ.get("LABSIM_ARTIFACTS", ROOT / "test-artifacts"))
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                 "--disable-component-update", "--no-first-run"]

HOW = ("install a browser to run them: `apt-get install chromium` (Debian/Ubuntu) and "
       "`pip install playwright`, or set LABSIM_CHROMIUM to a Chromium executable")


def _chromium() -> str | None:
    for candidate in (os.environ.get("LABSIM_CHROMIUM"), "chromium", "chromium-browser", "google-chrome"):
        if candidate and (shutil.which(candidate) or Path(candidate).is_file()):
            return shutil.which(candidate) or candidate
    return None


def _missing(why: str) -> None:
    if os.environ.get("CI", "").lower() == "true":
        pytest.fail(f"browser tests cannot run under CI: {why}; {HOW}")
    pytest.skip(f"browser tests skipped: {why}; {HOW}")


@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        _missing("the playwright package is not installed")
    exe = _chromium()
    if exe is None:
        _missing("no Chromium found")
    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=exe, args=CHROMIUM_ARGS)
        yield b
        b.close()


class View:
    """A running ``labsim view`` and a page open on it."""

    def __init__(self, browser: Any, args: list[str], query: str = "", wait: bool = True):
        self.proc = subprocess.Popen([sys.executable, "-m", "labsim", "view", *args, "--port", "0", "--no-browser"],
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT)
        assert self.proc.stdout is not None
        line = self.proc.stdout.readline()
        assert " at http" in line, self.proc.stderr.read() if self.proc.stderr else line
        self.url = line.split(" at ")[1].split()[0]
        # the page forbids eval (its CSP); Playwright evaluates the tests' conditions as strings
        self.browser = browser
        self.pages: list[Any] = []
        self.page = browser.new_page(viewport={"width": 1400, "height": 860}, bypass_csp=True)
        self.errors: list[str] = []
        self.page.on("pageerror", lambda e: self.errors.append(str(e)))
        self.page.goto(self.url + ("&" + query[1:] if query.startswith("?") and "?" in self.url else query))
        if wait:  # a file that does not compile shows no frames
            self.wait("window.labsimView.frames > 0")

    def another_page(self, width: int = 1400, height: int = 860) -> Any:
        """A second tab (a browser context of its own: it opens with the printed URL, the token in it)."""
        page = self.browser.new_page(viewport={"width": width, "height": height}, bypass_csp=True)
        page.on("pageerror", lambda e: self.errors.append(str(e)))
        page.goto(self.url)
        page.wait_for_function("window.labsimView.frames > 0", timeout=8000)
        self.pages.append(page)
        return page

    def wait(self, condition: str, timeout_ms: int = 8000) -> None:
        self.page.wait_for_function(condition, timeout=timeout_ms)

    def js(self, expression: str) -> Any:
        return self.page.evaluate(expression)

    def frame(self) -> dict:
        return self.js("window.labsimView.frame")

    def shot(self, name: str, selector: str | None = None) -> np.ndarray:
        ARTIFACTS.mkdir(parents=True, exist_ok=True)
        path = ARTIFACTS / f"{name}.png"
        if selector:
            self.page.locator(selector).screenshot(path=str(path))
        else:
            self.page.screenshot(path=str(path))
        img = cv2.imread(str(path))
        assert img is not None
        return img

    def close(self) -> None:
        if self.proc.returncode is not None:  # closed already (a test that reads the trace after)
            return
        self.page.close()
        for page in self.pages:
            page.close()
        self.proc.send_signal(signal.SIGINT)
        _, err = self.proc.communicate(timeout=20)
        assert self.proc.returncode == 130, err
        assert "Traceback" not in err
        assert not self.errors, self.errors


@pytest.fixture
def view(browser: Any) -> Iterator[Any]:
    opened: list[View] = []

    def start(args: list[str], query: str = "", wait: bool = True) -> View:
        v = View(browser, args, query, wait)
        opened.append(v)
        return v
    yield start
    for v in opened:
        v.close()


def test_crane_slider_moves_the_arm_and_the_crane(view: Any) -> None:
    v = view(["behaviours/crane.yaml"], "?chart=swing,tension")
    before = v.shot("crane-before", "#world")
    v.page.click("#play")
    v.wait("window.labsimView.frame.tick >= 10")
    dragged_at = v.frame()["time"]
    v.page.locator('input[data-name="arm"]').fill("5")
    v.wait("window.labsimView.frame.labels.speed === 'Arm Speed: 0.10'")
    v.wait("(window.labsimView.frame.mechanism.targets.Arm_Actuator || [])[1] === 5")  # the slider, as its velocity
    assert v.frame()["time"] - dragged_at <= 1.0
    # the page draws a frame on the next animation frame: wait for it rather than read at once
    # the script's one label, shown once; each slider its own name and value
    v.wait("[...document.querySelectorAll('#slider-labels .slider-label')].map((d) => d.textContent).join('|')"
           " === 'Arm Speed: 0.10'")
    names = v.js("[...document.querySelectorAll('#sliders .slider')].map((d) => [d.querySelector('.text')"
                 ".textContent, d.querySelector('.value').textContent])")
    assert [n for n, _ in names] == ["arm", "crab", "hoist"] and names[0][1] == "5"
    assert v.page.inner_text("#sliders-panel").count("Arm Speed") == 1
    v.page.select_option("#speed", "5")
    v.wait("window.labsimView.frame.time >= 6")
    after = v.shot("crane-after", "#world")
    v.shot("crane")
    # the hook and load have been lifted: the canvas differs where the crane is
    mask = np.abs(before.astype(int) - after.astype(int)).sum(axis=2) > 60
    ys, xs = np.nonzero(mask)
    assert len(xs) > 500
    # ... where the crane is: around the load, where it started and where it is now
    now, start = v.js("""(() => { const w = window.LV_world, f = window.labsimView.frame.mechanism.bodies.Load;
        const b = window.labsimView.scene.world.mechanism.bodies.find((q) => q.name === 'Load');
        return [w.toPx(f[0], f[1]), w.toPx(b.center[0], b.center[1])]; })()""")
    x0, x1 = int(min(now[0], start[0])) - 60, int(max(now[0], start[0])) + 60
    y0, y1 = int(min(now[1], start[1])) - 60, int(max(now[1], start[1])) + 60
    assert mask[max(0, y0):y1, max(0, x0):x1].sum() > 500


def test_wall_play_moves_the_robot_and_pause_holds_it(view: Any) -> None:
    v = view(["behaviours/wall_follow.yaml"])
    v.wait("window.labsimView.frame !== null")
    start = v.js("document.querySelector('#world') && window.labsimView.frame.robots[0].pose")
    v.page.click("#play")
    v.page.select_option("#speed", "10")
    v.wait("window.labsimView.frame.tick >= 60")
    v.wait("document.querySelector('#rule').textContent.includes(':')")
    moved = v.frame()["robots"][0]["pose"]
    assert moved[:2] != start[:2]
    assert v.page.locator("#state").inner_text() in ("wander", "follow")
    v.shot("wall")
    v.page.click("#play")  # now "Pause"
    v.wait("window.labsimView.frame.playing === false")
    held = v.frame()
    time.sleep(0.4)
    assert v.frame()["tick"] == held["tick"] and v.frame()["robots"][0]["pose"] == held["robots"][0]["pose"]
    v.wait("document.querySelector('#play').textContent === 'Play'")


def test_road_shows_five_robots_and_a_camera_image(view: Any) -> None:
    v = view(["behaviours/road_follow.yaml"])
    v.page.click("#play")
    v.wait("document.querySelectorAll('#images img').length === 2 && document.querySelector('#images img').complete"
           " && document.querySelector('#images img').naturalWidth > 0")
    assert len(v.frame()["robots"]) == 5
    v.page.select_option("#robot", "2")
    v.wait("window.labsimView.frame.images && window.labsimView.frame.images.robot === 2")
    camera = v.shot("road-camera", "#images figure:first-child img")
    assert camera.std() > 20  # road and floor: not blank
    v.wait("window.labsimView.frame.time >= 2")
    v.shot("road")


def test_replay_scrubs_to_a_tick_and_shows_its_pose(view: Any, tmp_path: Path) -> None:
    trace = tmp_path / "wall.csv"
    subprocess.run([sys.executable, "-m", "labsim", "run", "behaviours/wall_follow.yaml", "--set", "minutes=0.5",
                    "--trace", str(trace), "-q"], check=True, cwd=ROOT)
    rows = read_trace(trace)
    v = view([str(trace)])
    assert v.js("window.labsimView.scene.mode") == "replay"
    v.page.locator("#scrubber").fill("250")
    v.wait("window.labsimView.frame.tick === 250 && window.LV_world.drawnTick === 250")
    row = rows.rows[250]
    pose = v.frame()["robots"][0]["pose"]
    assert pose[:2] == [float(row[rows.columns.index("x")]), float(row[rows.columns.index("y")])]
    px = v.js("(() => { const p = window.labsimView.frame.robots[0].pose; "
              "return window.LV_world.toPx(p[0], p[1]); })()")
    got = v.js("window.LV_world.drawn[0]")
    assert abs(px[0] - got[0]) < 0.5 and abs(px[1] - got[1]) < 0.5
    v.shot("replay")


def test_malformed_messages_leave_the_page_and_run_working(view: Any) -> None:
    v = view(["behaviours/wall_follow.yaml"])
    v.js("""(() => { const ws = window.labsimView.ws;
        ws.send('{bad json'); ws.send(new Uint8Array([0, 1, 2])); ws.send('{"type": "slider", "name": 7}');
        ws.send('{"type": "speed", "value": -5}'); ws.send('"play"'); ws.send('{"type": "step"}'); })()""")
    v.wait("window.labsimView.frame.ran === 1")
    v.page.click("#step")
    v.wait("window.labsimView.frame.ran === 2")
    assert v.js("window.labsimView.ws.readyState") == 1


def _apart(boxes: list[dict]) -> list[tuple[int, int]]:
    """The pairs of label boxes that meet (CSS pixels, top-left corner, width and height)."""
    def meet(a: dict, b: dict) -> bool:
        return (a["x"] < b["x"] + b["w"] and b["x"] < a["x"] + a["w"]
                and a["y"] < b["y"] + b["h"] and b["y"] < a["y"] + a["h"])
    return [(i, j) for i in range(len(boxes)) for j in range(i + 1, len(boxes)) if meet(boxes[i], boxes[j])]


LAYOUTS = {  # robots' positions on a 600 x 400 canvas: name -> anchors
    "a row 10 px apart": [[300 + 10 * k, 200] for k in range(5)],
    "thirty on one spot": [[300, 200]] * 30,
    "in a corner": [[595, 5], [590, 8], [598, 2], [585, 10]],
    "a tight grid": [[280 + 12 * (k % 4), 180 + 12 * (k // 4)] for k in range(16)],
}


@pytest.mark.parametrize("name", sorted(LAYOUTS))
def test_label_layout_keeps_every_label_apart(view: Any, name: str) -> None:
    v = view(["behaviours/wall_follow.yaml"])
    anchors = LAYOUTS[name]
    order = list(range(len(anchors)))[::-1]  # the last robot is the picked one
    boxes = v.page.evaluate("([a, o]) => LV.layoutLabels(a, a.map((_, k) => [70 + k % 3 * 10, 15]),"
                            " {width: 600, height: 400, marker: 9}, o)", [anchors, order])
    assert all(b is not None for b in boxes)
    assert _apart(boxes) == []
    picked = boxes[order[0]]  # first served: right next to its robot, no line needed
    assert picked["leader"] is None
    alone = v.page.evaluate("LV.layoutLabels([[100, 100]], [[60, 15]], {width: 600, height: 400, marker: 9})")
    assert alone[0]["x"] > 100 and alone[0]["y"] + alone[0]["h"] < 100  # up-right, where it always was


def test_value_cells_print_two_decimals_as_a_label_does(view: Any) -> None:
    v = view(["behaviours/wall_follow.yaml"])
    values = [0.1, 0.125, 0.375, -0.125, -0.625, 2.675, 1.005, 3.14159, -0.001, 0.004, 123.456, 999999.5]
    got = v.page.evaluate("(vs) => vs.map(LV.fmt)", values)
    assert got == [format(x, ".2f") for x in values]
    whole = v.page.evaluate("[0, 5, -3, 1e6, 2.5e7, null, 'inf'].map(LV.fmt)")
    assert whole == ["0", "5", "-3", "1.00e+6", "2.50e+7", "–", "inf"]


def test_road_labels_stand_apart_at_the_start_and_values_show_two_decimals(view: Any) -> None:
    v = view(["behaviours/road_follow.yaml"])
    v.wait("window.LV_world.labels.filter((b) => b).length === 5")
    assert v.frame()["ran"] == 0 and "(not started)" in v.page.inner_text("#clock")
    boxes = v.js("window.LV_world.labels")
    assert _apart(boxes) == [], boxes
    width, height = v.js("[window.LV_world.canvas.clientWidth, window.LV_world.canvas.clientHeight]")
    assert all(0 <= b["x"] <= width - b["w"] and 0 <= b["y"] <= height - b["h"] for b in boxes)
    v.shot("road-labels", "#world")
    v.page.click("#step")  # no tick has read a sensor yet: one tick gives the table its numbers
    v.wait("window.labsimView.frame.ran === 1 && document.querySelector('#clock').textContent.includes('(tick 0)')")
    v.wait("[...document.querySelectorAll('#table td.value')].some((td) => /\\./.test(td.textContent))")
    cells = v.js("[...document.querySelectorAll('#table td.value')].map((td) => td.textContent)")
    assert any("." in c for c in cells)
    assert all(re.fullmatch(r"–|-?\d+|-?\d+\.\d\d|-?\d\.\d\de[+-]\d+|-?inf", c) for c in cells), cells
    v.shot("road-table")


# -- what the page must never get wrong ------------------------------------------------------

def _crossings(path: list, walls: list) -> list:
    """The drawn path's segments that cross a wall's centre line (world metres)."""
    def side(a: list, b: list, c: list) -> float:
        return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])

    out = []
    for p, q in itertools.pairwise(path):
        if p is None or q is None:
            continue
        for ax, ay, bx, by, _ in walls:
            a, b = [ax, ay], [bx, by]
            if side(a, b, p) * side(a, b, q) < 0 and side(p, q, a) * side(p, q, b) < 0:
                out.append((p, q, (ax, ay, bx, by)))
    return out


def test_the_path_drawn_at_full_speed_never_crosses_a_wall(view: Any) -> None:
    # ten hours: at top speed the lab's own 25 minutes can end before the pause lands
    v = view(["behaviours/wall_follow.yaml", "--set", "minutes=600"])
    v.page.select_option("#speed", "max")
    v.page.click("#play")
    v.wait("window.labsimView.frame.tick >= 9000", timeout_ms=60000)
    v.page.click("#play")  # pause
    v.wait("window.labsimView.frame.playing === false")
    path = v.js("window.LV_world.paths[0]")
    walls = v.js("window.labsimView.scene.world.walls")
    assert len(path) > 50
    assert _crossings(path, walls) == []
    # and the chart had a point for far more ticks than frames came
    samples = v.js("window.labsimView.frames"), v.js("window.LV_chart.history[0].t.length")
    assert samples[1] > 3 * samples[0], samples
    v.shot("wall-full-speed")


def test_the_end_of_a_run_at_full_speed_reaches_the_page(view: Any) -> None:
    v = view(["behaviours/wall_follow.yaml", "--set", "minutes=1"])
    v.page.select_option("#speed", "max")
    v.page.click("#play")
    v.wait("window.labsimView.frame.finished === true && window.labsimView.frame.playing === false",
           timeout_ms=60000)
    assert v.frame()["tick"] == 1199 and v.frame()["ran"] == 1200  # the trace's last row is tick 1199
    v.wait("document.querySelector('#clock').textContent.includes('ended')")


def _checked(v: Any) -> list[str]:
    return v.js("[...document.querySelectorAll('#table input[type=checkbox]')].filter((b) => b.checked)"
                ".map((b) => b.dataset.column)")


def test_chart_picks_hold_across_play_restart_and_robot_switches(view: Any) -> None:
    v = view(["behaviours/road_follow.yaml"])
    first = _checked(v)
    assert len(first) == 2
    v.page.select_option("#robot", "2")
    v.page.click("#play")
    v.wait("window.labsimView.frame.tick >= 20")
    assert _checked(v) == first
    v.page.locator(f'#table input[data-column="{first[0]}"]').uncheck()
    picked = _checked(v)
    v.page.click("#restart")
    v.wait("window.labsimView.frame && window.labsimView.frame.ran === 0")
    v.wait("document.querySelectorAll('#chart .u-over').length === 1")
    assert _checked(v) == picked and v.js("window.labsimView.robot") == 2
    v.page.click("#play")
    v.wait("window.labsimView.frame.tick >= 10")
    v.page.select_option("#robot", "0")
    v.wait("window.labsimView.frame.tick >= 20")
    assert _checked(v) == picked
    assert v.js("document.querySelectorAll('#chart-now .now').length") == 1
    v.shot("road-chart-after-restart")


def test_check_again_after_a_fix_says_live(view: Any, tmp_path: Path) -> None:
    good = (ROOT / "behaviours" / "wall_follow.yaml").read_text()
    lab = tmp_path / "wall.yaml"
    lab.write_text(good.replace("minutes: 25", "minutes: 25\n  oops: [", 1))
    v = view([str(lab)], wait=False)
    v.wait("document.querySelector('#status').textContent === 'does not compile'")
    lab.write_text(good)
    v.page.click("#recheck")
    v.wait("document.querySelector('#status').textContent === 'live'")
    v.page.click("#play")
    v.wait("window.labsimView.frame.tick >= 5")
    assert v.js("document.querySelector('#diagnostics').hidden")


def test_a_slider_value_follows_the_thumb_during_a_drag(view: Any) -> None:
    v = view(["behaviours/crane.yaml"])
    box = v.page.locator('input[data-name="arm"]').bounding_box()
    y = box["y"] + box["height"] / 2
    v.page.mouse.move(box["x"] + box["width"] / 2, y)
    v.page.mouse.down()
    v.page.mouse.move(box["x"] + box["width"] * 0.8, y, steps=8)
    value, shown = v.js("""(() => { const i = document.querySelector('input[data-name="arm"]');
        return [Number(i.value), i.parentElement.querySelector('.value').textContent]; })()""")
    assert value > 3 and shown == v.page.evaluate("(x) => LV.fmt(x)", value)
    assert re.fullmatch(r"-?\d+(\.\d\d)?", shown)
    v.page.mouse.up()


def test_the_grid_s_scale_and_the_slew_dial_s_captions_stand_apart(view: Any) -> None:
    v = view(["behaviours/crane.yaml"])
    for width, height in ((1400, 860), (1280, 800), (1920, 1080)):
        v.page.set_viewport_size({"width": width, "height": height})
        v.page.click("#step")  # a frame drawn at this size
        v.wait("window.LV_world.dialBox && document.getElementById('grid-scale').textContent.startsWith('grid ')")
        v.page.wait_for_timeout(200)
        dial = v.js("window.LV_world.dialBox")
        label = v.js("(() => { const c = document.getElementById('world').getBoundingClientRect(),"
                     " g = document.getElementById('grid-scale').getBoundingClientRect();"
                     " return { left: g.left - c.left, top: g.top - c.top, right: g.right - c.left,"
                     " bottom: g.bottom - c.top }; })()")
        apart = (label["bottom"] <= dial["top"] or dial["bottom"] <= label["top"]
                 or label["right"] <= dial["left"] or dial["right"] <= label["left"])
        assert apart, (width, label, dial)
    v.page.set_viewport_size({"width": 1400, "height": 860})
    v.page.wait_for_timeout(200)
    v.shot("crane-grid-scale-and-dial", "#world")


def test_a_crane_trace_replays_the_mechanism_it_holds(view: Any, tmp_path: Path) -> None:
    trace = tmp_path / "crane.csv"
    subprocess.run([sys.executable, "-m", "labsim", "run", "behaviours/crane.yaml", "--trace", str(trace), "-q"],
                   check=True, cwd=ROOT)
    v = view([str(trace)])
    v.wait("document.querySelector('#status').textContent === 'replay'")
    v.page.locator("#scrubber").fill("400")
    v.wait("window.labsimView.frame.tick === 400 && window.LV_world.drawnTick !== undefined")
    mech = v.frame()["mechanism"]
    assert {"Crab", "Upper_guide", "Load"} <= set(mech["bodies"]) and mech["missing"] == ["Gripper"]
    assert "Gripper" in mech["note"]
    v.shot("crane-replay")


def test_a_breakpoint_pauses_on_the_tick_the_trace_says_it_first_holds(view: Any, tmp_path: Path) -> None:
    trace = tmp_path / "wall.csv"
    subprocess.run([sys.executable, "-m", "labsim", "run", "behaviours/wall_follow.yaml", "--set", "minutes=0.5",
                    "--trace", str(trace), "-q"], check=True, cwd=ROOT)
    rows = read_trace(trace)
    sonar5 = rows.columns.index("sonar5")
    first = next(int(r[0]) for r in rows.rows if float(r[sonar5]) < 0.5)
    v = view(["behaviours/wall_follow.yaml", "--break", "sonar5 < 0.5"])
    v.page.select_option("#speed", "max")
    v.page.click("#play")
    v.wait("window.labsimView.frame.hit !== null && window.labsimView.frame.playing === false", timeout_ms=30000)
    hit = v.frame()["hit"]
    assert hit["tick"] == first and hit["what"] == "sonar5 < 0.5"
    row = rows.rows[first]
    assert hit["state"] == row[rows.columns.index("state")] and (hit["rule"] or "") == row[rows.columns.index("rule")]
    v.wait(f"document.querySelector('#break-hit').textContent.includes('Paused on tick {first}')")
    # the header says the tick paused on, whose rule and values are shown, at its time
    assert f"(tick {first})" in v.page.inner_text("#clock")
    assert v.page.inner_text("#clock").startswith(f"t = {first * 0.05:.2f} s")
    assert v.page.inner_text("#rule").startswith(hit["rule"] or "(none fired)")
    assert v.page.inner_text("#state") == (hit["state"] or "–")
    # the chart has what the condition reads, up to this tick, and its legend the values then
    v.wait("document.querySelector('#table input[data-column=\"sonar5\"]').checked")
    k = rows.columns.index("sonar5")
    t, values = v.js("(() => { const c = LV_chart, k = c.columns.findIndex((q) => q.name === 'sonar5');"
                     " return [c.history[0].t, c.history[0].cols[k]]; })()")
    assert abs(t[-1] - first * 0.05) < 1e-9 and 0 < values[-1] < 0.5
    # every frame's samples, from the run's start on (a frame's samples are thinned: the first may be tick 1 or 2)
    assert len(t) > 10 and t[0] <= 0.1
    by_tick = {int(r[0]): float(r[k]) for r in rows.rows}
    # a row is a tick's value, or (at full speed) a group's least or greatest: one of the values
    # recorded from the row before it to the row after it
    for j, (time_s, value) in enumerate(zip(t, values)):
        lo = round(t[j - 1] / 0.05) if j else 0
        hi = round(t[j + 1] / 0.05) if j + 1 < len(t) else round(time_s / 0.05)
        seen = [by_tick[q] for q in range(lo, hi + 1)]
        assert value is None or any(v == value or abs(v - value) < 1e-3 for v in seen), (time_s, value)
    legend = v.js("[...document.querySelectorAll('#chart .u-legend .u-value')].map((e) => e.textContent)")
    assert "--" not in legend[1:], legend
    v.shot("breakpoint")
    v.page.click("#step")  # one tick on, and the breakpoint is behind
    v.wait(f"window.labsimView.frame.tick === {first + 1} && window.labsimView.frame.hit === null")
    # a breakpoint from the page: a mistake is shown with its column, a good one pauses the run
    v.page.fill("#break-text", "sonr5 < 1")
    v.page.click("#break-form button")
    v.wait("document.querySelector('#notice').textContent.includes(\"did you mean 'sonar5'\")")
    rule = rows.columns.index("rule")
    later = [(int(r[0]), r[rule]) for r in rows.rows if int(r[0]) >= first + 2]
    pick = next(name for _, name in later if name and name != later[0][1])
    v.page.select_option("#break-kind", "rule")
    v.page.fill("#break-text", pick)
    v.page.click("#break-form button")
    v.wait("window.labsimView.frame.breakpoints.length === 2")
    v.page.click("#play")
    v.wait(f"window.labsimView.frame.hit !== null && window.labsimView.frame.hit.what === 'rule:{pick}'",
           timeout_ms=30000)
    assert v.frame()["hit"]["tick"] == next(t for t, name in later if name == pick)
    v.shot("breakpoint-rule")


def test_a_dragged_robot_replays_from_the_trace_row_for_row(view: Any, tmp_path: Path) -> None:
    trace, replayed = tmp_path / "live.csv", tmp_path / "replayed.csv"
    v = view(["behaviours/wall_follow.yaml", "--trace", str(trace)])
    v.page.click("#step")
    v.wait("window.labsimView.frame.ran === 1 && window.LV_world.drawn[0] !== undefined")
    # onto the wall at x = 3 m: refused, with a message; the robot stays
    box = v.page.locator("#world").bounding_box()  # the canvas' pixels, on the page

    def on_page(expression: str) -> list[float]:
        x, y = v.js(expression)
        return [box["x"] + x, box["y"] + y]
    wall = on_page("window.LV_world.toPx(3.0, -5.0)")
    at = on_page("window.LV_world.drawn[0]")
    v.page.mouse.move(at[0], at[1])
    v.page.mouse.down()
    v.page.mouse.move(wall[0], wall[1], steps=6)
    v.page.mouse.up()
    v.wait("document.querySelector('#notice').textContent.includes('was not moved')")
    # two metres to the right of where it stands: moved, and the next ticks start there
    pose = v.frame()["robots"][0]["pose"]
    to = on_page(f"window.LV_world.toPx({pose[0] + 2.0}, {pose[1]})")
    v.page.mouse.move(at[0], at[1])
    v.page.mouse.down()
    v.page.mouse.move(to[0], to[1], steps=6)
    v.shot("drag")
    v.page.mouse.up()
    v.wait(f"Math.abs(window.labsimView.frame.robots[0].pose[0] - {pose[0] + 2.0}) < 0.05")
    v.page.select_option("#speed", "10")
    v.page.click("#play")
    v.wait("window.labsimView.frame.tick >= 60")
    v.page.click("#play")
    v.wait("window.labsimView.frame.playing === false")
    v.shot("drag-after")
    v.close()  # Ctrl-C: the trace so far is kept
    subprocess.run([sys.executable, "-m", "labsim", "run", "behaviours/wall_follow.yaml", "--replay", str(trace),
                    "--trace", str(replayed), "-q"], check=True, cwd=ROOT, capture_output=True)
    a, b = read_trace(trace), read_trace(replayed)
    assert any(e.startswith("place pioneer ") for e in a.column("events"))
    assert b.rows[:len(a.rows)] == a.rows


def test_the_editor_shows_errors_inline_keeps_the_run_and_restarts_on_a_fix(view: Any, tmp_path: Path) -> None:
    lab = tmp_path / "wall.yaml"
    text = (ROOT / "behaviours" / "wall_follow.yaml").read_text()
    lab.write_text(text)
    v = view([str(lab)])
    v.page.select_option("#speed", "10")
    v.page.click("#play")
    v.wait("window.labsimView.frame.tick >= 20")
    v.page.click("#edit")
    v.wait("!document.querySelector('#editor-panel').hidden")
    assert v.page.input_value("#source") == text
    v.page.fill("#source", text.replace("sonar5", "sonr5", 1))
    v.page.click("#apply")
    v.wait("document.querySelectorAll('#problems li').length > 0")
    line = next(i for i, t in enumerate(text.split("\n"), 1) if "sonar5" in t)
    assert v.page.locator("#problems li").first.inner_text().startswith(f"line {line}, column ")
    assert v.js("[...document.querySelectorAll('#gutter .bad')].map((d) => Number(d.textContent))") == [line]
    v.shot("editor-error")
    ticked = v.frame()["tick"]
    v.wait(f"window.labsimView.frame.tick > {ticked}")  # the old run goes on
    v.page.fill("#source", text.replace("minutes: 25", "minutes: 1"))
    v.page.click("#apply")
    v.wait("document.querySelector('#editor-state').textContent === 'applied, not saved'")
    # a restart sends the scene, then frames: between the two the page has no frame
    v.wait("window.labsimView.frame && window.labsimView.frame.tick < 20 && window.labsimView.scene.stop_s === 60")
    assert v.js("document.querySelectorAll('#problems li').length") == 0
    v.shot("editor")
    asked: list[str] = []
    v.page.once("dialog", lambda d: (asked.append(d.message), d.dismiss()))
    v.page.click("#save")  # asked first: Cancel writes nothing
    v.page.wait_for_timeout(300)
    assert asked == [f"Save over {lab}? The file on disk is replaced by this text."] and lab.read_text() == text
    v.page.once("dialog", lambda d: d.accept())
    v.page.click("#save")
    v.wait("document.querySelector('#editor-state').textContent === ''")
    assert lab.read_text() == text.replace("minutes: 25", "minutes: 1")


def test_read_only_turns_the_editor_off_and_says_so(view: Any) -> None:
    v = view(["behaviours/wall_follow.yaml", "--read-only"])
    v.wait("!document.querySelector('#read-only').hidden")
    v.page.click("#edit")
    assert v.js("document.querySelector('#source').readOnly && document.querySelector('#apply').disabled "
                "&& document.querySelector('#save').disabled")


def test_blocks_moved_added_and_removed_replay_from_the_trace_row_for_row(view: Any, tmp_path: Path) -> None:
    trace, replayed = tmp_path / "live.csv", tmp_path / "replayed.csv"
    v = view(["behaviours/wall_follow.yaml", "--trace", str(trace)])
    v.page.click("#step")
    v.wait("window.labsimView.frame.ran === 1 && !document.querySelector('#block-tools').hidden")
    box = v.page.locator("#world").bounding_box()

    def on_page(x: float, y: float) -> list[float]:
        px, py = v.js(f"window.LV_world.toPx({x}, {y})")
        return [box["x"] + px, box["y"] + py]

    def drag(a: list[float], b: list[float]) -> None:
        v.page.mouse.move(*a)
        v.page.mouse.down()
        v.page.mouse.move(*b, steps=6)
        v.page.mouse.up()
    # the box in the far corner (centre 6.5, 6.5) onto the inner wall: refused, said, nothing moves
    drag(on_page(6.5, 6.5), on_page(0.0, 1.5))
    v.wait("document.querySelector('#notice').textContent.includes('block 0 was not moved')")
    assert "blocks" not in v.frame()
    drag(on_page(6.5, 6.5), on_page(4.5, 6.0))  # two metres west, half a metre south
    v.wait("window.labsimView.frame.blocks !== undefined")
    (k, corners), = v.frame()["blocks"]
    assert k == 0 and abs(sum(c[0] for c in corners) / 4 - 4.5) < 0.05
    v.page.click("#add-block")
    v.page.mouse.click(*on_page(-6.0, 6.0))
    v.wait("window.labsimView.frame.blocks.length === 2")
    v.page.select_option("#speed", "10")
    v.page.click("#play")
    v.wait("window.labsimView.frame.tick >= 30")
    v.page.mouse.click(*on_page(4.5, 6.0))  # pick the moved box, then remove it, while running
    v.wait("!document.querySelector('#remove-block').disabled")
    v.page.click("#remove-block")
    v.wait("window.labsimView.frame.blocks.length === 1 && window.labsimView.frame.blocks[0][0] === 1")
    v.wait("window.labsimView.frame.tick >= 60")
    v.page.click("#play")
    v.wait("window.labsimView.frame.playing === false")
    v.shot("blocks")
    v.close()  # Ctrl-C: the trace so far is kept
    subprocess.run([sys.executable, "-m", "labsim", "run", "behaviours/wall_follow.yaml", "--replay", str(trace),
                    "--trace", str(replayed), "-q"], check=True, cwd=ROOT, capture_output=True)
    a, b = read_trace(trace), read_trace(replayed)
    events = [e.split(" ")[:3] for cell in a.column("events") for e in cell.split(";") if e.startswith("block ")]
    assert events == [["block", "move", "0"], ["block", "add", "1"], ["block", "remove", "0"]]
    assert b.rows[:len(a.rows)] == a.rows


def _wall_trace(tmp_path: Path) -> Path:
    trace = tmp_path / "wall.csv"
    subprocess.run([sys.executable, "-m", "labsim", "run", "behaviours/wall_follow.yaml", "--set", "minutes=0.5",
                    "--trace", str(trace), "-q"], check=True, cwd=ROOT)
    return trace


def _seek(v: Any, tick: int, robot: bool = True) -> None:
    v.page.locator("#scrubber").fill(str(tick))
    v.wait(f"window.labsimView.frame.tick === {tick}" + (f" && window.LV_world.drawnTick === {tick}" if robot else ""))
    v.wait(f"window.LV_chart.history[0].t.length === {tick + 1}")


def test_a_replay_seek_draws_only_recorded_rows_and_scrubbing_gives_the_same(view: Any, tmp_path: Path) -> None:
    trace = _wall_trace(tmp_path)
    rows = read_trace(trace)
    x, y = rows.columns.index("x"), rows.columns.index("y")
    v = view([str(trace)])
    _seek(v, 500)  # forward, past 500 rows never played
    path = v.js("window.LV_world.paths[0]")
    recorded = [[float(r[x]), float(r[y])] for r in rows.rows[:501]]
    assert path == recorded  # every row's point, nothing across the skipped time
    times = v.js("window.LV_chart.history[0].t")
    assert times == [round(k * 0.05, 9) for k in range(501)]
    assert v.page.locator("#clock").text_content().startswith("t = 25.00 s")
    assert v.page.locator("#rtf").text_content() == ""  # a seek is not speed: no 612x
    first = v.shot("replay-seek-500", "#world")
    _seek(v, 120)
    assert v.js("window.LV_world.paths[0]") == recorded[:121]
    _seek(v, 500)
    assert v.js("window.LV_world.paths[0]") == path and v.js("window.LV_chart.history[0].t") == times
    again = v.shot("replay-seek-500-again", "#world")
    assert np.array_equal(first, again)  # the same picture, however the scrubber got there


def test_a_crane_replay_seek_holds_the_sliders_at_their_recorded_values(view: Any, tmp_path: Path) -> None:
    trace = tmp_path / "crane.csv"
    subprocess.run([sys.executable, "-m", "labsim", "run", "behaviours/crane.yaml", "--trace", str(trace), "-q"],
                   check=True, cwd=ROOT)
    rows = read_trace(trace)
    v = view([str(trace)], "?chart=arm,crab")
    _seek(v, 1000, robot=False)
    k = v.js("window.labsimView.scene.columns.findIndex((c) => c.name === 'arm')")
    drawn = v.js(f"window.LV_chart.history[0].cols[{k}]")
    arm = rows.columns.index("arm")
    assert drawn == [float(r[arm]) for r in rows.rows[:1001]]  # a step where it moved, flat where it held
    v.shot("replay-crane-seek", "#chart")


def test_a_second_tab_receives_the_run_so_far(view: Any) -> None:
    v = view(["behaviours/wall_follow.yaml", "--set", "minutes=600"])  # still running when paused
    v.page.select_option("#speed", "max")
    v.page.click("#play")
    v.wait("window.labsimView.frame.tick >= 3000", timeout_ms=60000)
    v.page.click("#play")  # pause
    v.wait("window.labsimView.frame.playing === false")
    first = v.js("window.LV_world.paths[0]")
    second = v.another_page()
    second.wait_for_function("window.LV_world.drawnTick !== null")
    path = second.evaluate("window.LV_world.paths[0]")
    assert len(first) > 50
    assert len(path) >= len(first) and path[-1] == first[-1] and path[0] == first[0]
    assert second.evaluate("window.LV_chart.history[0].t.length") >= 0.9 * v.js("window.LV_chart.history[0].t.length")
    second.reload()  # a reload too
    second.wait_for_function("window.LV_world.drawnTick !== null && window.LV_world.paths[0].length > 50")
    assert second.evaluate("window.LV_world.paths[0]") == path


def _events(page: Any) -> list[str]:
    return page.evaluate("[...document.querySelectorAll('#events li:not(.more)')].map((li) => li.textContent)")


def test_a_second_tab_and_a_reload_receive_the_run_s_events(view: Any, tmp_path: Path) -> None:
    trace = tmp_path / "wall.csv"
    v = view(["behaviours/wall_follow.yaml", "--trace", str(trace), "--break", "time:300"])
    v.page.select_option("#speed", "max")
    v.page.click("#play")
    v.wait("window.labsimView.frame.hit !== null && window.labsimView.frame.playing === false", timeout_ms=60000)
    second = v.another_page()
    second.wait_for_function("document.querySelectorAll('#events li').length > 0")
    events = _events(second)
    # what the first tab listed from its frames, the second has too, in the same order
    first = [e for e in _events(v.page) if e in events]
    assert first == [e for e in events if e in first] and len(first) > 0
    v.close()  # the trace, complete, to compare with
    rows = read_trace(trace)
    state, tick = rows.columns.index("state"), rows.columns.index("tick")
    entered = [f"t = {int(b[tick]) * 0.05:.2f} s  state {a[state]} → {b[state]}"
               for a, b in zip(rows.rows, rows.rows[1:]) if a[state] != b[state]]
    assert entered and [e for e in events if " state " in e] == entered
    collided = rows.columns.index("collided")
    begun = sum(1 for a, b in zip(rows.rows, rows.rows[1:]) if b[collided] == "1" and a[collided] != "1")
    assert sum(" collision at (" in e for e in events) == begun
    assert events[-1] == "t = 300.00 s  breakpoint: time:300"


def test_a_reload_keeps_a_slider_move_in_the_events(view: Any) -> None:
    v = view(["behaviours/crane.yaml"])
    v.page.click("#play")
    v.wait("window.labsimView.frame.tick >= 5")
    v.page.focus('input[data-name="arm"]')
    v.page.keyboard.press("ArrowRight")
    v.wait("[...document.querySelectorAll('#events li')].some((li) => li.textContent.includes(' arm='))")
    v.page.click("#play")  # pause
    v.wait("window.labsimView.frame.playing === false")
    before = _events(v.page)
    v.page.reload()
    v.wait("window.labsimView.frames > 0 && document.querySelectorAll('#events li').length > 0")
    after = _events(v.page)
    assert [e for e in after if " arm=" in e] == [e for e in before if " arm=" in e]
    assert len([e for e in after if " arm=" in e]) == 1


def test_two_breakpoints_on_one_tick_are_both_named_and_state_shows_the_state_entered(view: Any,
                                                                                     tmp_path: Path) -> None:
    trace = _wall_trace(tmp_path)
    rows = read_trace(trace)
    state = rows.columns.index("state")
    entered = next(int(b[0]) for a, b in zip(rows.rows, rows.rows[1:]) if a[state] != b[state])
    assert rows.rows[entered][state] == "follow"
    at = f"time:{entered * 0.05:.2f}"
    v = view(["behaviours/wall_follow.yaml", "--break", at, "--break", "state:follow"])
    v.page.select_option("#speed", "max")
    v.page.click("#play")
    v.wait("window.labsimView.frame.hit !== null && window.labsimView.frame.playing === false", timeout_ms=30000)
    v.wait(f"document.querySelector('#break-hit').textContent.includes('Paused on tick {entered}')")
    text = v.page.inner_text("#break-hit")
    assert text.startswith(f"Paused on tick {entered} (t = {entered * 0.05:.2f} s): {at} and state:follow — "
                           "state follow, rule "), text
    assert v.page.inner_text("#state") == "follow"
    v.shot("breakpoint-two-on-one-tick", "#breaks-panel")


def _steer_is_a_band(v: Any, shot: str) -> None:
    """The line lab's chart of steer and laps: steer, which flips sign about 15 times a simulated
    second, a band; laps, a count that steps up once a lap, a line."""
    v.page.wait_for_timeout(300)  # the chart drawn after the pause
    img = v.shot(shot, "#chart canvas")
    steer_px = np.all(np.abs(img.astype(int) - (0xbd, 0x67, 0x94)) < 40, axis=2).sum(axis=0)  # #9467bd, BGR
    laps_px = np.all(np.abs(img.astype(int) - (0x4b, 0x56, 0x8c)) < 40, axis=2).sum(axis=0)  # #8c564b
    drawn = steer_px > 0
    assert drawn.sum() > 0.5 * img.shape[1]
    # the band: nearly every column the line crosses is filled over most of the swing
    assert (steer_px[drawn] > 0.5 * steer_px.max()).mean() > 0.8, np.percentile(steer_px[drawn], [10, 50, 90])
    assert steer_px.max() > 0.3 * img.shape[0]
    # and laps stays a line: a few pixels a column
    assert np.percentile(laps_px[laps_px > 0], 90) <= 6, np.percentile(laps_px[laps_px > 0], [50, 90])
    band = v.js("window.LV_chart.drawn[1].band.filter((b) => b !== null)")
    assert sum(b > 20 for b in band) > 0.8 * len(band)


def _pairs_are_the_trace_s_least_and_greatest(trace: Path, t: list[float], steer: list[float]) -> None:
    """The chart's rows of steer (times ``t``) that stand for a group of ticks are its least and
    greatest over those ticks, as the trace has them, and many are a band across zero."""
    rows = read_trace(trace)
    k, dt = rows.columns.index("steer"), 0.02
    by_tick = [float(r[k]) for r in rows.rows]
    pairs = [(a, b) for a, b in zip(zip(t, steer), list(zip(t, steer))[1:]) if b[0] - a[0] > 2.5 * dt]
    assert len(pairs) >= 10
    bands = 0
    for (t0, a), (t1, b) in pairs[-40:]:  # the least first, or the greatest where it only fell
        ticks = by_tick[round(t0 / dt): round(t1 / dt) + 1]
        low, high = min(a, b), max(a, b)
        assert abs(low - min(ticks)) < 1e-3 and abs(high - max(ticks)) < 1e-3, (t0, t1, a, b)
        assert a == low or ticks == sorted(ticks, reverse=True), (t0, t1, a, b)
        bands += low < 0 < high
    assert bands >= 5


def test_a_15_hz_flip_is_drawn_as_an_envelope_and_every_axis_has_three_ticks(view: Any, tmp_path: Path) -> None:
    trace = tmp_path / "line.csv"
    v = view(["behaviours/line_follow.yaml", "--trace", str(trace), "--set", "minutes=60"], "?chart=steer,laps")
    v.page.select_option("#speed", "max")  # an hour: still running when paused
    v.page.click("#play")
    v.wait("window.labsimView.frame.tick >= 3000", timeout_ms=60000)
    v.page.click("#play")  # pause
    v.wait("window.labsimView.frame.playing === false")
    t, steer = v.js("(() => { const c = LV_chart, k = c.columns.findIndex((q) => q.name === 'steer');"
                    " return [c.history[0].t, c.history[0].cols[k]]; })()")
    # steer flips sign about 15 times a simulated second, hundreds of ticks a frame at this speed:
    # evenly spread picks drew slow pulses. A group of ticks is sent as two rows, at its first
    # tick its least value and at its last its greatest, and drawn as the band the signal fills
    # (per pixel column its least and greatest), not as a sawtooth between the two rows
    _steer_is_a_band(v, "chart-envelope")
    v.close()  # the trace, complete, to compare with
    _pairs_are_the_trace_s_least_and_greatest(trace, t, steer)
    v = view(["behaviours/line_follow.yaml"], "?chart=steer,ahead")
    v.page.click("#step")
    v.page.click("#step")
    v.wait("window.LV_chart.plot.axes.every((a) => a._values && a._values.filter((x) => x !== '').length >= 3)")
    v.shot("chart-two-ticks", "#chart")
    # a column with no number (an image, a record) has nothing to tick
    assert v.js("[...document.querySelectorAll('#table input[type=checkbox]')].filter((b) => !b.hidden)"
                ".every((b) => window.labsimView.scene.columns.find((c) => c.name === b.dataset.column)"
                ".numeric !== false)")


# per pixel column of the chart's canvas, the least and greatest canvas row of the [time, value]
# given, on the first picked signal's scale: what an envelope must cover there
TRUE_SPAN = """(vals) => {
  const u = LV_chart.plot, sy = u.series[1].scale, cols = {};
  for (const [t, y] of vals) {
    const c = Math.round(u.valToPos(t, "x", true)), py = Math.round(u.valToPos(y, sy, true));
    const q = cols[c] || (cols[c] = [py, py]);
    q[0] = Math.min(q[0], py); q[1] = Math.max(q[1], py);
  }
  return [window.devicePixelRatio, cols];
}"""


def _covers_every_peak(v: Any, steer: list[tuple[float, float]], shot: str) -> None:
    """The chart's first signal (#9467bd), as the page shows it, covers in every pixel column
    what the ticks there span, give or take a pixel (a sawtooth between least and greatest rows
    crosses a column as a short slant, and misses the swing)."""
    v.page.wait_for_timeout(300)  # drawn after the last frame
    img = v.shot(shot, "#chart canvas")
    purple = np.all(np.abs(img.astype(int) - (0xbd, 0x67, 0x94)) < 60, axis=2)
    ratio, truth = v.page.evaluate(TRUE_SPAN, steer)
    assert ratio == 1
    missed, swings = [], 0
    for c, (lo, hi) in ((int(c), q) for c, q in truth.items()):
        rows = np.nonzero(purple[:, max(0, c - 1):c + 2].any(axis=1))[0]
        swings += hi - lo > 20
        if not len(rows) or rows.min() > lo + 2 or rows.max() < hi - 2:
            missed.append((c, lo, hi, (int(rows.min()), int(rows.max())) if len(rows) else None))
    assert len(missed) <= 0.01 * len(truth), missed[:10]
    assert swings > 50  # and there are wide swings to cover


def test_a_replay_draws_the_envelope_the_live_chart_draws(view: Any, tmp_path: Path) -> None:
    trace = tmp_path / "line.csv"
    subprocess.run([sys.executable, "-m", "labsim", "run", "behaviours/line_follow.yaml", "--trace", str(trace), "-q"],
                   check=True, cwd=ROOT)
    rows = read_trace(trace)
    k = rows.columns.index("steer")
    steer = [(round(j * 0.02, 9), float(r[k])) for j, r in enumerate(rows.rows)]
    end = len(rows.rows) - 1
    v = view([str(trace)], "?chart=steer,laps")
    script = ("(() => { const c = LV_chart, k = c.columns.findIndex((q) => q.name === 'steer');"
              " return [c.history[0].t, c.history[0].cols[k]]; })()")
    # a seek: the history up to tick 4500, as pairs of groups of ticks (a live page's history too)
    v.page.locator("#scrubber").fill("4500")
    v.wait("window.labsimView.frame.tick === 4500 && window.LV_chart.history[0].t.length > 1000")
    t, drawn = v.js(script)
    assert len(t) <= 2001
    _pairs_are_the_trace_s_least_and_greatest(trace, t, drawn)
    _covers_every_peak(v, steer[:4501], "replay-chart-seek")
    # played on at top speed: each frame carries pairs of the rows since the last, drawn as bands
    v.page.select_option("#speed", "max")
    v.page.click("#play")
    v.wait(f"window.labsimView.frame.tick === {end} && window.labsimView.frame.playing === false", timeout_ms=60000)
    t, drawn = v.js(script)
    after = [(a, b) for a, b in zip(t, drawn) if a > 4500 * 0.02]
    assert len(after) < 0.2 * (end - 4500)  # pairs of groups, not every row
    _pairs_are_the_trace_s_least_and_greatest(trace, [a for a, _ in after], [b for _, b in after])
    _covers_every_peak(v, steer, "replay-chart-played")


def test_slider_keys_while_playing_all_count_and_each_move_is_recorded_once(view: Any, tmp_path: Path) -> None:
    trace = tmp_path / "crane.csv"
    v = view(["behaviours/crane.yaml", "--trace", str(trace)])
    scene = v.js("window.labsimView.scene")
    arm = next(s for s in scene["sliders"] if s["name"] == "arm")
    step = (arm["max"] - arm["min"]) / 200
    v.page.click("#play")
    v.wait("window.labsimView.frame.tick >= 5")
    start = v.js("Number(document.querySelector('input[data-name=\"arm\"]').value)")
    v.page.focus('input[data-name="arm"]')
    for _ in range(10):
        v.page.keyboard.press("ArrowRight")
        v.page.wait_for_timeout(60)
    want = start + 10 * step
    v.wait(f"Math.abs(window.labsimView.frame.sliders.arm - {want}) < 1e-9", timeout_ms=8000)
    v.page.wait_for_timeout(1000)  # frames from before the keys no longer move it back
    assert abs(v.js("Number(document.querySelector('input[data-name=\"arm\"]').value)") - want) < 1e-9
    v.page.click("#play")  # pause
    v.close()
    rows = read_trace(trace)
    events = [e for r in rows.rows for e in r[rows.columns.index("events")].split(";") if "arm" in e]
    assert events and all(a != b for a, b in itertools.pairwise(events)), events  # no move recorded twice


def test_the_page_says_when_the_run_ended_and_when_the_server_stopped(view: Any) -> None:
    v = view(["behaviours/wall_follow.yaml", "--set", "minutes=0.1"])
    v.page.select_option("#speed", "max")
    v.page.click("#play")
    v.wait("!document.querySelector('#ended').hidden", timeout_ms=30000)
    assert v.page.inner_text("#ended") == ("The run has ended at t = 5.95 s (its stop condition held). "
                                           "Restart runs it again.")
    assert v.js("['play', 'step', 'speed'].map((id) => document.getElementById(id).disabled)") == [True] * 3
    assert not v.js("document.getElementById('restart').disabled")
    v.shot("view-ended")
    v.proc.send_signal(signal.SIGINT)  # a clean end: the server says goodbye
    v.wait("document.querySelector('#ended').textContent.startsWith('labsim view has stopped')")
    assert v.page.inner_text("#status") == "stopped"
    # what would send something is off (Edit file still shows the file)
    disabled = v.js("[...document.querySelectorAll('#play, #step, #restart, #speed, #apply, #save, #params input, "
                    "#break-form button, #break-form input')].map((e) => [e.id || e.tagName, e.disabled])")
    assert len(disabled) >= 8 and all(d for _, d in disabled), disabled
    v.shot("view-stopped")
    v.page.wait_for_timeout(2500)
    assert v.js("window.labsimView.ws.readyState") == 3 and not v.js("window.labsimView.retries")  # no knocking
    v.proc.communicate(timeout=20)


def test_a_lost_server_is_retried_with_back_off(view: Any) -> None:
    v = view(["behaviours/wall_follow.yaml"])
    v.proc.kill()  # no goodbye: the connection is just gone
    v.proc.communicate(timeout=20)
    v.wait("document.querySelector('#ended').textContent.includes('Trying again in 1 s (attempt 1)')")
    v.wait("document.querySelector('#ended').textContent.includes('Trying again in 2 s (attempt 2)')")
    v.wait("document.querySelector('#ended').textContent.includes('Trying again in 4 s (attempt 3)')",
           timeout_ms=10000)
    assert v.js("document.getElementById('play').disabled")
    v.proc.returncode = 130  # ended here on purpose: the fixture has nothing to stop


def test_an_epuck_is_drawn_to_scale_with_its_ground_sensors(view: Any) -> None:
    v = view(["behaviours/line_follow.yaml"])
    v.page.click("#step")
    v.wait("window.LV_world.drawnTick === 0 && window.LV_world.marks.length === 1")
    whole = v.shot("line-world", "#world")
    assert (whole.max(axis=2) < 60).sum() > 2000  # the floor's black line is drawn (the ground under the robots)
    scene = v.js("window.labsimView.scene")
    reach = scene["robots"][0]["reach"]
    assert reach == pytest.approx(0.035, abs=0.003)
    v.js("window.LV_world.moved = true; window.LV_world.scale = 2000;"
         " const p = window.labsimView.frame.robots[0].pose;"
         " window.LV_world.cx = p[0]; window.LV_world.cy = p[1]; window.LV_world.draw()")
    marks = v.js("window.LV_world.marks[0]")
    assert marks["reach"] == pytest.approx(reach * 2000, rel=0.01)  # 7 cm across, at this zoom 140 px
    assert marks["nose"] == pytest.approx(1.5 * reach * 2000, rel=0.01)  # not 0.35 m, ten times the robot
    assert marks["ground"] == 3 == len(v.frame()["robots"][0]["ground"])
    img = v.shot("epuck-close", "#world")
    # the ground sensors are squares the grey of their readings, ringed orange
    orange = (np.abs(img.astype(int) - np.array([14, 127, 255])).sum(axis=2) < 60).sum()
    assert orange > 30


# a robot that drives into the wall and backs off, every four seconds: a collision each time (the
# handout's wall lab touches no wall)
BUMPER = """labsim: 1.2
name: Bumps
world: walls_lab4
stop: time >= 30
robots:
  pioneer: {model: pioneer_p3dx, at: [6.9, -4, 0]}
rules:
  - if time % 4 < 2 then move(4)
  - else move(-4)
"""


def test_collisions_are_marked_on_the_path_and_counted(view: Any, tmp_path: Path) -> None:
    bumps = tmp_path / "bumps.yaml"
    bumps.write_text(BUMPER, encoding="utf-8")
    v = view([str(bumps)])
    v.page.select_option("#speed", "max")
    v.page.click("#play")
    v.wait("window.labsimView.frame.finished === true", timeout_ms=60000)
    count = v.frame()["robots"][0]["collisions"]
    assert count > 0
    v.wait(f"document.getElementById('hits').textContent === '{count}'")
    v.wait(f"window.LV_world.marks[0].hits === {count}")
    v.shot("collisions", "#world")


def test_near_misses_are_marked_on_the_path_and_counted_as_on_the_map(view: Any, tmp_path: Path) -> None:
    # the map of labsim plot marks each rise of a count metric (the wall lab's near_misses:
    # count(min(ahead, right, left) < 0.25)) with a triangle, and counts them; so does the page
    trace = tmp_path / "wall.csv"
    v = view(["behaviours/wall_follow.yaml", "--trace", str(trace), "--set", "side=0.15", "--set", "minutes=2"])
    v.page.select_option("#speed", "max")
    v.page.click("#play")
    v.wait("window.labsimView.frame.finished === true && window.labsimView.frame.playing === false", timeout_ms=60000)
    v.page.wait_for_timeout(300)  # the last frame drawn
    shown = v.page.inner_text("#counts [data-name='near_misses'] strong")
    drawn = v.js("window.LV_world.marks[0].counted")
    second = v.another_page()
    second.wait_for_function("window.LV_world.drawnTick !== null && window.LV_world.marks[0]")
    drawn_later = second.evaluate("window.LV_world.marks[0].counted")
    v.shot("near-misses", "#world")
    v.close()
    rows = read_trace(trace)
    k = rows.columns.index("events")
    rose = sum(e == "near_misses" for r in rows.rows for e in r[k].split(";"))
    assert rose > 0
    assert shown == str(rose) and drawn == rose and drawn_later == rose


def _box(page: Any, selector: str) -> dict:
    return page.locator(selector).bounding_box()


def _disjoint(a: dict, b: dict) -> bool:
    """Two page boxes that do not overlap (touching edges allowed)."""
    return (a["x"] + a["width"] <= b["x"] + 0.5 or b["x"] + b["width"] <= a["x"] + 0.5
            or a["y"] + a["height"] <= b["y"] + 0.5 or b["y"] + b["height"] <= a["y"] + 0.5)


@pytest.mark.parametrize(("lab", "width", "height"), [("wall_follow", 390, 844), ("road_follow", 390, 844),
                                                       ("wall_follow", 360, 740), ("road_follow", 360, 740)])
def test_layout_on_a_phone_stacks_the_panels_under_a_world_nothing_covers(view: Any, lab: str, width: int,
                                                                         height: int) -> None:
    v = view([f"behaviours/{lab}.yaml"])
    v.page.set_viewport_size({"width": width, "height": height})
    v.page.wait_for_timeout(300)
    world, aside = _box(v.page, "#world"), _box(v.page, "aside")
    # a world about as tall as the screen is wide, not a strip
    assert world["width"] >= width - 40 and world["height"] >= 300 and world["height"] >= 0.9 * world["width"], world
    assert aside["y"] >= world["y"] + world["height"] and aside["width"] >= width - 40, aside  # under it, full width
    assert v.js("document.documentElement.scrollWidth") <= width + 10  # nothing sideways
    # nothing over the world: the block tools, the grid's scale and the help stand beside it
    assert not v.page.locator("#block-tools").is_hidden()
    for selector in ("#add-block", "#remove-block", "#grid-scale", ".canvas-help"):
        box = _box(v.page, selector)
        assert box["height"] > 0 and _disjoint(box, world), (selector, box, world)
    assert v.page.inner_text("#grid-scale").startswith("grid ")
    robot = v.js("window.LV_world.drawn[0]")  # the world fitted to the new size: the robot in sight
    assert 0 <= robot[0] <= world["width"] and 0 <= robot[1] <= world["height"], robot
    # every robot drawn at its model's size: radius = model radius x scale, to the pixel; too
    # small to see at a phone's zoom, so a locator ring around it larger than its body
    scale = v.js("window.LV_world.scale")
    reaches = [r["reach"] for r in v.js("window.labsimView.scene")["robots"]]
    marks = v.js("window.LV_world.marks")
    assert len(marks) == len(reaches) >= 1
    for mark, reach in zip(marks, reaches):
        assert abs(mark["reach"] - reach * scale) < 1, (mark, reach, scale)
        assert mark["locator"] > 2 * mark["reach"], mark
    # the robots' name labels inside the world, each clear of the tools row above it
    labels = [b for b in v.js("window.LV_world.labels") if b]
    assert len(labels) == (len(reaches) if len(reaches) > 1 else 0)
    for b in labels:
        assert b["x"] >= 0 and b["y"] >= 0, b
        assert b["x"] + b["w"] <= world["width"] + 1 and b["y"] + b["h"] <= world["height"] + 1, b
    chart = _box(v.page, ".chart-panel")
    legend = _box(v.page, "#chart .u-legend")
    assert legend["y"] + legend["height"] <= chart["y"] + chart["height"] + 1  # the legend inside its panel
    img = v.shot(f"layout-{width}-{lab}", "#world")
    # in the picture: the first robot's colour (#1f77b4) on its locator ring, and nowhere between
    # the ring and the robot's true size (a body drawn bigger than the robot would fill that gap)
    x, y = robot
    ys, xs = np.mgrid[0:img.shape[0], 0:img.shape[1]]
    d = np.hypot(xs + 0.5 - x, ys + 0.5 - y)
    blue = np.abs(img.astype(int) - np.array([180, 119, 31])).sum(axis=2) < 90  # BGR, some blending allowed
    ring = marks[0]["locator"]
    assert blue[np.abs(d - ring) < 1.5].sum() >= 10
    assert blue[(d > marks[0]["reach"] + 2) & (d < ring - 2.5)].sum() == 0
    v.shot(f"layout-{width}-{lab}-page")


def test_layout_at_1280x800_shows_sliders_chart_and_editor_together(view: Any) -> None:
    v = view(["behaviours/crane.yaml"], "?chart=swing,tension")
    v.page.set_viewport_size({"width": 1280, "height": 800})
    v.page.click("#edit")
    for name in ("crab_x", "load_x", "rope"):  # tick signals far down the table
        box = v.page.locator(f'#table input[data-column="{name}"]')
        box.scroll_into_view_if_needed()
        box.check()
    v.page.wait_for_timeout(300)
    for selector in ("#sliders-panel", "#chart", "#editor-panel", "#world"):
        b = _box(v.page, selector)
        assert b["y"] >= 0 and b["y"] + b["height"] <= 800 and b["height"] > 100, (selector, b)
    assert _box(v.page, "#world")["height"] >= 140
    v.shot("layout-1280x800")


def test_the_readme_and_docs_screenshots_are_taken_from_the_page_as_it_is(browser: Any) -> None:
    """tests/browser/view_screenshots.py, into the artifacts: the README's and docs' pictures
    of the view are made by a script the browser stage runs, never by hand."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("view_screenshots", Path(__file__).with_name("view_screenshots.py"))
    assert spec is not None and spec.loader is not None
    shots = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(shots)
    written = shots.take(browser, ARTIFACTS / "screenshots")
    assert [p.name for p in written] == ["view-crane.png", "view-road.png", "view-wall.png", "view-breakpoint.png",
                                         "view-editor.png"]
    for path in written:
        img = cv2.imread(str(path))
        assert img is not None and img.shape[:2] == (860, 1400) and img.std() > 10, path


def test_the_scrubber_follows_after_a_click_and_arrow_right_goes_forward(view: Any, tmp_path: Path) -> None:
    v = view([str(_wall_trace(tmp_path))])
    v.page.locator("#scrubber").click()  # the middle of the bar: a seek there
    v.wait("window.labsimView.frame.tick > 100")
    clicked = v.frame()["tick"]
    v.page.click("#play")
    v.wait(f"window.labsimView.frame.tick >= {clicked + 20}", timeout_ms=20000)
    v.page.click("#play")  # pause
    v.wait("window.labsimView.frame.playing === false")
    now = v.frame()["tick"]
    v.wait(f"document.getElementById('scrubber').value === '{now}'")  # it followed the replay
    v.page.focus("#scrubber")
    v.page.keyboard.press("ArrowRight")
    v.wait(f"window.labsimView.frame.tick === {now + 1}")  # one row on, not back to where it was clicked


OTHER_ROBOTS = """labsim: 1.3
world: walls_lab4
stop: time >= 60
robots:
  leader: {model: pioneer_p3dx, at: [0, 0, 0], params: {lead: true}}
  follower: {model: pioneer_p3dx, at: [-2, 0, 0]}
params:
  lead: false
let:
  gap: hypot(leader.x - x, leader.y - y)
  pinged: heard(ping)
rules:
  wait:
    - when lead then say(ping, tick)
    - if time >= 0.2 and leader.state == wait then goto go
    - else move(1)
  go:
    - when lead then say(ping, tick)
    - else move(2)
"""


def test_the_table_lists_what_a_robot_reads_of_the_others(view: Any, tmp_path: Path) -> None:
    """Format 1.3: 'leader.x', 'leader.state' and 'heard(ping)' under "other robots", with their values."""
    path = tmp_path / "other_robots.yaml"
    path.write_text(OTHER_ROBOTS)
    v = view([str(path)])
    for _ in range(12):
        v.page.click("#step")
    # the frame of tick 11 drawn (its table is filled on the animation frame after it arrives)
    v.wait("window.labsimView.frame.tick >= 11 && !window.labsimView.unacked")
    table = "Array.from(document.querySelectorAll('#table tbody tr')).map((tr) => tr.innerText.trim())"

    def shown() -> dict[str, str]:
        rows = v.js(table)
        group = rows.index("other robots")
        return dict(r.split("\t")[:2] for r in rows[group + 1:group + 5])
    leader = shown()
    assert list(leader) == ["leader.x", "leader.y", "leader.state", "heard(ping)"]
    assert leader["leader.state"] == "go" and leader["heard(ping)"] == "–"  # it does not hear itself
    v.page.select_option("#robot", "1")
    v.wait("Array.from(document.querySelectorAll('#table tbody tr')).some((tr) => tr.innerText.includes('10'))")
    follower = shown()
    assert follower["leader.state"] == "go" and follower["heard(ping)"] == "10"  # said on tick 10, heard on 11
    assert float(follower["leader.x"]) > 0 and follower["leader.x"] == leader["leader.x"]
    v.shot("other_robots")
