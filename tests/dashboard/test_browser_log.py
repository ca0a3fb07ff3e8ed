"""The events-and-alarms panel in real headless chromium over the real AGV fleet."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest

from agv_app.fleet import Fleet, FleetConfig
from tests.dashboard.browser import BROWSER_MARKS, chromium_page, load_dashboard
from tests.dashboard.served import Served
from tests.dashboard.test_browser_tasks import CLIPPED_CELLS

pytestmark = BROWSER_MARKS


@pytest.fixture
def log_page() -> Iterator[tuple[Any, Served, Fleet]]:
    fleet = Fleet(config=FleetConfig(agvs=4, seed=3, task_until=0.0))
    with Served(fleet) as served:
        with chromium_page() as (page, problems):
            load_dashboard(page, served)
            yield page, served, fleet
        assert problems == [], problems


def test_a_pause_and_a_failed_agv_show_with_the_alarm_on_top(
    log_page: tuple[Any, Served, Fleet],
) -> None:
    page, served, fleet = log_page
    reason = "aisle 3 blocked by a pallet that fell off a shelf"
    r = served.post("/api/sim/pause", {"reason": reason})
    assert r.status_code == 200
    page.locator("#events-body td", has_text=f"fleet paused: {reason}").wait_for(timeout=5_000)
    victim = sorted(fleet.agvs)[0]
    fleet.crash(victim)  # paused: the driver does not advance the fleet meanwhile
    alarm = page.locator(f"#alarms li[data-alarm-key='failed:{victim}']")
    alarm.wait_for(timeout=5_000)
    assert alarm.text_content().endswith(f"{victim} failed")
    page.locator("#events-body td", has_text=f"node {victim} left").wait_for(timeout=5_000)
    first_row = page.locator("#events-body tr").first
    assert first_row.locator("td[data-severity]").text_content() in {"alarm", "warning"}
    alarms_box = page.locator("#alarms").bounding_box()
    table_box = page.locator("#log-panel table").bounding_box()
    assert alarms_box["y"] < table_box["y"], "active alarms stand above the log"
    assert page.evaluate(CLIPPED_CELLS, "#log-panel") == []
