"""The README's and docs/view.md's pictures of ``labsim view``, taken from the page as it is.

    python tests/browser/view_screenshots.py [--out DIR]

Starts ``labsim view`` on the labs, drives the page in a headless Chromium (Playwright) as a
student would, and writes ``view-crane.png``, ``view-road.png``, ``view-wall.png`` (the
README's, in ``docs/``) and ``images/view-breakpoint.png``, ``images/view-editor.png``
(docs/view.md's) under DIR (default: the repository's ``docs``). The browser test stage runs
it into its artifacts (tests/browser/test_view_browser.py), so the pictures never fall behind
the page; look at them before committing them.
"""
from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[2]
SIZE = {"width": 1400, "height": 860}


class _View:
    def __init__(self, browser: Any, args: list[str], query: str = ""):
        self.proc = subprocess.Popen([sys.executable, "-m", "labsim", "view", *args, "--port", "0", "--no-browser"],
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT)
        assert self.proc.stdout is not None
        line = self.proc.stdout.readline()
        if " at http" not in line:
            raise RuntimeError(f"labsim view did not start: {line}")
        url = line.split(" at ")[1].split()[0]
        self.page = browser.new_page(viewport=SIZE, bypass_csp=True)
        self.page.goto(url + ("&" + query if query else ""))
        self.wait("window.labsimView.frames > 0")

    def wait(self, condition: str, timeout_ms: int = 30000) -> None:
        self.page.wait_for_function(condition, timeout=timeout_ms)

    def close(self) -> None:
        self.page.close()
        self.proc.send_signal(signal.SIGINT)
        self.proc.communicate(timeout=20)


def take(browser: Any, out: Path) -> list[Path]:
    """Every picture, written under ``out``; their paths."""
    (out / "images").mkdir(parents=True, exist_ok=True)
    written = []

    v = _View(browser, ["behaviours/crane.yaml"], "chart=swing,tension")
    v.page.click("#play")
    v.wait("window.labsimView.frame.tick >= 20")
    v.page.locator('input[data-name="arm"]').fill("5")
    v.wait("window.labsimView.frame.time >= 6")
    v.page.click("#play")
    v.wait("window.labsimView.frame.playing === false")
    v.page.wait_for_timeout(300)
    written.append(out / "view-crane.png")
    v.page.screenshot(path=str(written[-1]))
    v.close()

    v = _View(browser, ["behaviours/road_follow.yaml"])
    v.page.click("#play")
    v.wait("window.labsimView.frame.time >= 4 && document.querySelectorAll('#images img').length > 0")
    v.page.click("#play")
    v.page.wait_for_timeout(300)
    written.append(out / "view-road.png")
    v.page.screenshot(path=str(written[-1]))
    v.close()

    v = _View(browser, ["behaviours/wall_follow.yaml"], "chart=ahead,right")
    v.page.select_option("#speed", "10")
    v.page.click("#play")
    v.wait("window.labsimView.frame.time >= 40", timeout_ms=60000)
    v.page.click("#play")
    v.page.wait_for_timeout(300)
    written.append(out / "view-wall.png")
    v.page.screenshot(path=str(written[-1]))
    v.close()

    v = _View(browser, ["behaviours/wall_follow.yaml", "--break", "sonar5 < 0.5"])
    v.page.select_option("#speed", "max")
    v.page.click("#play")
    v.wait("window.labsimView.frame.hit !== null && !window.labsimView.frame.playing")
    v.page.wait_for_timeout(300)
    written.append(out / "images" / "view-breakpoint.png")
    v.page.screenshot(path=str(written[-1]))
    v.close()

    v = _View(browser, ["behaviours/wall_follow.yaml"])
    v.page.click("#play")
    v.page.click("#edit")
    text = v.page.input_value("#source")
    v.page.fill("#source", text.replace("ahead <= front", "ahaed <= front", 1))
    v.page.click("#apply")
    v.wait("document.querySelectorAll('#problems li').length > 0")
    v.page.wait_for_timeout(300)
    written.append(out / "images" / "view-editor.png")
    v.page.screenshot(path=str(written[-1]))
    v.close()
    return written


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "docs")
    args = parser.parse_args()
    from playwright.sync_api import sync_playwright

    exe = os.environ.get("LABSIM_CHROMIUM", "chromium")
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=subprocess.run(["which", exe], capture_output=True, text=True)
                                    .stdout.strip() or exe, args=["--headless", "--no-sandbox", "--disable-gpu"])
        for path in take(browser, args.out):
            print(path)
        browser.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
