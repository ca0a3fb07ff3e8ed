"""Dashboard frame rate in headless chromium: 200 AGVs against 1 AGV in the same run.

Serves the real fleet (``agv_app.fleet.demo_source``) with the dashboard on a loopback
port, opens the page in Debian's chromium, turns on every hull-projection circle, and
reads the page's own frame-rate meter for a while.

Run: .venv/bin/python bench/dashboard.py [--sizes 1,200] [--seconds 10]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from playwright.sync_api import sync_playwright

from agv_app.fleet import demo_source
from bench.report import markdown_table, publish
from tests.dashboard.browser import CHROMIUM, CHROMIUM_ARGS
from tests.dashboard.served import Served


def measure(agvs: int, seconds: float) -> tuple[float, float, float]:
    """Median and lowest frame rate, and the feed messages per second, over ``seconds``."""
    fleet = demo_source(agvs=agvs, seed=1)
    with Served(fleet) as served, sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_ARGS)
        page = browser.new_page(viewport={"width": 1400, "height": 900})
        page.goto(served.login_url())  # the login page sends the browser on to the dashboard
        page.wait_for_url(served.url + "/", timeout=20_000)
        page.wait_for_function("window.__dashboard && window.__dashboard.ready", timeout=20_000)
        page.check("#toggle-circles")
        page.wait_for_timeout(2000)
        samples = []
        start_messages = page.evaluate("window.__dashboard.messages")
        start = time.monotonic()
        while time.monotonic() - start < seconds:
            page.wait_for_timeout(500)
            samples.append(float(page.evaluate("window.__dashboard.fps")))
        rate = (page.evaluate("window.__dashboard.messages") - start_messages) / seconds
        browser.close()
    return statistics.median(samples), min(samples), rate


def main() -> None:
    """Measure each size and publish the section."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="1,200")
    parser.add_argument("--seconds", type=float, default=10.0)
    args = parser.parse_args()
    rows = []
    for n in (int(s) for s in args.sizes.split(",")):
        median, lowest, rate = measure(n, args.seconds)
        rows.append([n, f"{median:.0f}", f"{lowest:.0f}", f"{rate:.1f}"])
    body = (
        f"Headless Debian chromium, 1400x900 viewport, all hull-projection circles on, "
        f"{args.seconds:g} s per size after 2 s of warm-up; the page's own frame-rate meter "
        "(requestAnimationFrame), sampled twice a second.\n\n"
        + markdown_table(["AGVs", "fps median", "fps lowest", "feed messages/s"], rows)
        + "\n\nGoal (issue 6): no lower than about 20 fps with 200 AGVs."
    )
    publish(
        "dashboard",
        "Dashboard frame rate (bench/dashboard.py)",
        body,
        f".venv/bin/python bench/dashboard.py --sizes {args.sizes} --seconds {args.seconds:g}",
    )


if __name__ == "__main__":
    main()
