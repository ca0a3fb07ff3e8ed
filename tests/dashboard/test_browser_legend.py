"""The floor plan's legend names every colour a hull or a station can take."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest

from tests.dashboard.browser import BROWSER_MARKS, chromium_page, load_dashboard
from tests.dashboard.conftest import NetworkSource
from tests.dashboard.served import Served

pytestmark = BROWSER_MARKS

HULL_STATUSES = {
    "idle", "driving", "moving", "waiting", "blocked", "loading", "unloading",
    "charging", "failed", "crashed", "stopping", "stopped", "out-of-service", "other",
    "to-charger", "empty",
}  # fmt: skip


@pytest.fixture
def page(source: NetworkSource) -> Iterator[Any]:
    with Served(source) as served, chromium_page() as (page, _):
        load_dashboard(page, served)
        yield page


def test_every_hull_colour_has_a_legend_entry(page: Any) -> None:
    entries = page.evaluate(
        """() => [...document.querySelectorAll('#hull-colors [data-hull-status]')].map((e) => [
            e.dataset.hullStatus, getComputedStyle(e.querySelector('.sw')).backgroundColor])"""
    )
    named = {status for statuses, _ in entries for status in statuses.split()}
    assert named == HULL_STATUSES
    colours = [colour for _, colour in entries]
    assert len(colours) == len(set(colours)), "one entry per colour"
    assert len(colours) == 9
    kinds = page.evaluate(
        """() => [...document.querySelectorAll('#station-colors [data-station-kind]')]
            .map((e) => e.dataset.stationKind)"""
    )
    assert {k for ks in kinds for k in ks.split()} >= {"pick", "drop", "pickdrop", "parking"}
    legend = page.locator("#legend").bounding_box()
    assert legend["x"] + legend["width"] <= page.locator("#floor-wrap").bounding_box()["width"]
