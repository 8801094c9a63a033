"""``labsim grade``'s pages in a real headless Chromium: the overview shows its charts, a feedback
page the caret diagnostics and the map. Without a Chromium (or playwright) the tests skip and
say how to install one, except under CI (``CI=true``). Screenshots go to ``test-artifacts/``
(or ``$LABSIM_ARTIFACTS``)."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from helpers import FIXTURES, ROOT

pytestmark = pytest.mark.slow  # a headless Chromium and a graded class

ARTIFACTS = Path(os.environ.get("LABSIM_ARTIFACTS", ROOT / "test-artifacts"))
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                 "--disable-component-update", "--no-first-run"]
HOW = ("install a browser to run them: `apt-get install chromium` (Debian/Ubuntu) and "
       "`pip install playwright`, or set LABSIM_CHROMIUM to a Chromium executable")
STUDENTS = ("valid_01", "valid_05", "valid_11", "nan_wheels", "compile_many_errors", "passwd_world", "renamed_metric")


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
    exe = next((shutil.which(c) or c for c in (os.environ.get("LABSIM_CHROMIUM"), "chromium", "chromium-browser",
                                               "google-chrome") if c and (shutil.which(c) or Path(c).is_file())), None)
    if exe is None:
        _missing("no Chromium found")
    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=exe, args=CHROMIUM_ARGS)
        yield b
        b.close()


@pytest.fixture(scope="module")
def pages(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A small class graded with its pages: the out folder."""
    folder = tmp_path_factory.mktemp("grade")
    shutil.copy(FIXTURES / "grading" / "assignment.yaml", folder)
    shutil.copy(FIXTURES / "grading" / "reference.yaml", folder)
    (folder / "class").mkdir()
    for name in STUDENTS:
        shutil.copy(FIXTURES / "grading" / "class" / f"{name}.yaml", folder / "class")
    done = subprocess.run([sys.executable, "-m", "labsim", "grade", "assignment.yaml", "class", "--out", "out",
                           "-j", "2"], cwd=folder, capture_output=True, text=True, timeout=600)
    assert done.returncode == 1, done.stderr
    return folder / "out"


def _open(browser: Any, path: Path) -> tuple[Any, list[str]]:
    page = browser.new_page(viewport={"width": 1200, "height": 900})
    asked: list[str] = []
    page.on("request", lambda r: asked.append(r.url))
    page.goto(path.as_uri())
    page.wait_for_load_state("load")
    return page, asked


def _shot(page: Any, name: str) -> Path:
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    path = ARTIFACTS / f"{name}.png"
    page.screenshot(path=str(path), full_page=True)
    return path


def test_the_overview_shows_its_charts_and_every_student(browser: Any, pages: Path) -> None:
    page, asked = _open(browser, pages / "index.html")
    widths = page.eval_on_selector_all(".charts img", "imgs => imgs.map(i => i.naturalWidth)")
    assert len(widths) == 4 and all(w > 100 for w in widths)  # the score and the three metrics, drawn
    assert page.locator("table a").count() == len(STUDENTS)
    assert "hostile file" in page.inner_text("body") and "contract mismatch" in page.inner_text("body")
    assert all(url.startswith("file://") for url in asked)  # nothing from the network
    _shot(page, "grade_overview")


def test_a_feedback_page_shows_the_carets_and_the_map(browser: Any, pages: Path) -> None:
    page, asked = _open(browser, pages / "feedback" / "compile_many_errors.html")
    shown = page.inner_text("pre.diagnostics")
    assert shown.count("^") == 3 and "did you mean 'sonar9'?" in shown
    assert page.locator("img.map").count() == 0 and page.locator("img.animation").count() == 0  # it never ran
    _shot(page, "grade_feedback_errors")
    page, asked = _open(browser, pages / "feedback" / "nan_wheels.html")
    assert page.eval_on_selector("img.map", "i => i.naturalWidth") > 400
    # the short animation: small, loaded from beside the page, nothing from the network
    assert page.eval_on_selector("img.animation", "i => i.complete && i.naturalWidth") == 400
    gif = pages / "feedback" / "nan_wheels.gif"
    assert gif.read_bytes()[:6] == b"GIF89a" and gif.stat().st_size < 200_000
    assert all(url.startswith("file://") for url in asked)
    text = page.inner_text("body")
    assert "Runtime faults" in text and "nan wheel command" in text and "fail" in text
    _shot(page, "grade_feedback_map")
