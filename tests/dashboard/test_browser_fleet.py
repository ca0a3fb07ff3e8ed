"""The page over the real AGV fleet, in real headless chromium: AGVs move between two
screenshots, and a task added by clicking a station is picked up by an AGV."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from agv_app.fleet import demo_source
from tests.dashboard.browser import BROWSER_MARKS, chromium_page, load_dashboard
from tests.dashboard.served import Served, wait_for

pytestmark = BROWSER_MARKS


@pytest.fixture
def fleet_page(tmp_path: Path) -> Iterator[tuple[Any, Any]]:
    fleet = demo_source(agvs=6, seed=3)
    fleet.set_speed(8.0)  # eight simulated seconds per wall second: visible motion soon
    with Served(fleet) as served:
        with chromium_page() as (page, problems):
            load_dashboard(page, served)
            yield page, fleet
        assert problems == [], problems


def test_agvs_move_between_two_screenshots(fleet_page: tuple[Any, Any], tmp_path: Path) -> None:
    page, _ = fleet_page
    before = page.evaluate("window.__dashboard.vehicles()")
    assert len(before) == 6
    first, second = tmp_path / "fleet-1.png", tmp_path / "fleet-2.png"
    page.screenshot(path=str(first))

    def moved() -> bool:
        now = page.evaluate("window.__dashboard.vehicles()")
        return any(now[v][:2] != before[v][:2] for v in before)

    wait_for(moved, 30.0, "an AGV moves")
    page.screenshot(path=str(second))
    assert first.read_bytes() != second.read_bytes()


def test_a_task_added_by_clicking_a_station_is_picked_up(fleet_page: tuple[Any, Any]) -> None:
    page, _ = fleet_page
    pos = page.evaluate("window.__dashboard.stationScreenPosition('pick-A1-1')")
    page.mouse.click(pos["x"], pos["y"])
    page.wait_for_function("window.__dashboard.lastTask !== null", timeout=5_000)
    task = page.evaluate("window.__dashboard.lastTask")
    assert task["station"] == "pick-A1-1"

    def carried_by() -> str | None:
        vehicles = page.evaluate("window.__dashboard.vehicles()")
        return next((v for v, (_, _, _, t) in vehicles.items() if t == task["id"]), None)

    agv = wait_for(carried_by, 45.0, f"an AGV takes {task['id']}")
    assert agv.startswith("agv")
