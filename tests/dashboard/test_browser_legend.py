"""The floor plan's legend names every colour a hull or a station can take."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest

from tests.dashboard.conftest import NetworkSource
from tests.dashboard.served import Served
from tests.dashboard.test_browser import CHROMIUM, CHROMIUM_ARGS

pytestmark = [
    pytest.mark.browser,
    pytest.mark.skipif(not CHROMIUM.exists(), reason="needs /usr/bin/chromium (make chromium)"),
]

HULL_STATUSES = {
    "idle", "driving", "moving", "waiting", "blocked", "loading", "unloading",
    "charging", "failed", "crashed", "other",
}  # fmt: skip


@pytest.fixture
def page(source: NetworkSource) -> Iterator[Any]:
    sync_api = pytest.importorskip("playwright.sync_api")
    with Served(source) as served, sync_api.sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_ARGS)
        page = browser.new_page(viewport={"width": 1400, "height": 900})
        page.goto(served.url + "/")
        page.wait_for_function("window.__dashboard && window.__dashboard.ready", timeout=10_000)
        yield page
        browser.close()


def test_every_hull_colour_has_a_legend_entry(page: Any) -> None:
    entries = page.evaluate(
        """() => [...document.querySelectorAll('#hull-colors [data-hull-status]')].map((e) => [
            e.dataset.hullStatus, getComputedStyle(e.querySelector('.sw')).backgroundColor])"""
    )
    named = {status for statuses, _ in entries for status in statuses.split()}
    assert named == HULL_STATUSES
    colours = [colour for _, colour in entries]
    assert len(colours) == len(set(colours)), "one entry per colour"
    assert len(colours) == 7
    kinds = page.evaluate(
        """() => [...document.querySelectorAll('#station-colors [data-station-kind]')]
            .map((e) => e.dataset.stationKind)"""
    )
    assert {k for ks in kinds for k in ks.split()} >= {"pick", "drop", "pickdrop", "parking"}
    legend = page.locator("#legend").bounding_box()
    assert legend["x"] + legend["width"] <= page.locator("#floor-wrap").bounding_box()["width"]
