"""The transport-orders panel in real headless chromium over the real AGV fleet."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest

from agv_app.fleet import Fleet, FleetConfig
from tests.dashboard.browser import BROWSER_MARKS, chromium_page, load_dashboard
from tests.dashboard.served import Served

pytestmark = BROWSER_MARKS

CLIPPED_CELLS = """(panel) => [...document.querySelectorAll(`${panel} td, ${panel} th`)]
    .filter((c) => c.scrollWidth > c.clientWidth + 1)
    .map((c) => c.textContent)
    .concat(
      [...document.querySelectorAll(`${panel} table`)]
        .filter((t) => t.scrollWidth > t.parentElement.clientWidth + 1)
        .map((t) => `table of ${panel}`),
    )"""
"""Cells (and tables) of a panel whose content is wider than they show: clipped."""


@pytest.fixture
def tasks_page() -> Iterator[tuple[Any, Served]]:
    # No random tasks, and paused: a created task waits until the test resumes.
    fleet = Fleet(config=FleetConfig(agvs=4, seed=3, task_until=0.0))
    fleet.set_speed(8.0)
    fleet.pause()
    with Served(fleet) as served:
        with chromium_page() as (page, problems):
            load_dashboard(page, served)
            yield page, served
        # A refused cancel (409) is logged by chromium as a failed resource; nothing else.
        assert [p for p in problems if "409" not in p] == [], problems


def create(served: Served, station: str) -> str:
    r = served.post("/api/tasks", {"station": station})
    assert r.status_code == 201, r.text
    return str(r.json()["task_id"])


def test_a_waiting_order_is_listed_and_cancelled(tasks_page: tuple[Any, Served]) -> None:
    page, served = tasks_page
    task_id = create(served, "pick-A1-1")
    row = page.locator(f"#tasks-panel tr[data-task-id='{task_id}']")
    row.wait_for(timeout=5_000)
    assert row.locator("td[data-state]").text_content() == "waiting"
    assert row.locator("td[data-creator]").text_content() == "api"
    assert row.locator("td").nth(2).text_content() == "pick-A1-1"
    assert page.evaluate(CLIPPED_CELLS, "#tasks-panel") == []
    row.locator("button.cancel").click()
    page.wait_for_function(
        f"document.querySelector(\"tr[data-task-id='{task_id}'] td[data-state]\")"
        ".textContent === 'cancelled'",
        timeout=5_000,
    )
    assert page.locator("#tasks-status").text_content() == f"task {task_id} cancelled"
    assert row.locator("button.cancel").count() == 0


def test_a_driving_order_has_no_cancel_and_the_filter_works(
    tasks_page: tuple[Any, Served],
) -> None:
    page, served = tasks_page
    first = create(served, "pick-A1-1")
    served.post("/api/sim/resume")
    page.wait_for_function(
        f"document.querySelector(\"tr[data-task-id='{first}'] td[data-state]\")"
        "?.textContent === 'driving'",
        timeout=30_000,
    )
    row = page.locator(f"tr[data-task-id='{first}']")
    assert row.locator("td").nth(5).text_content().startswith("agv")
    assert row.locator("button.cancel").count() == 0
    page.select_option("#tasks-state", "waiting")
    page.wait_for_function(
        "document.querySelectorAll('#tasks-body tr').length === 0", timeout=5_000
    )
    page.select_option("#tasks-state", "driving")
    row.wait_for(timeout=5_000)
    assert page.evaluate(CLIPPED_CELLS, "#tasks-panel") == []
