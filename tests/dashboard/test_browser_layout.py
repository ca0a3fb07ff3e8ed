"""No panel's table is clipped at 1400x900 or 1920x1080, with every panel filled: the
vehicle panel open, a session's history and a live group view shown, orders listed."""

from __future__ import annotations

import json
import time
from collections.abc import Iterator
from typing import Any

import pytest
from playwright.sync_api import TimeoutError as PlaywrightTimeoutError

from agv_app.fleet import Fleet, FleetConfig
from tests.dashboard.browser import BROWSER_MARKS, chromium_page, load_dashboard
from tests.dashboard.served import Served

pytestmark = BROWSER_MARKS

CLIPPED = """() => {
    const out = [];
    const wide = (e) => e.scrollWidth > e.clientWidth + 1;
    const say = (what, e) => out.push(`${what}: ${e.scrollWidth} > ${e.clientWidth}`);
    const aside = document.querySelector('aside');
    if (wide(aside)) say('aside', aside);
    for (const panel of document.querySelectorAll('aside .panel')) {
        if (panel.hidden) continue;
        if (wide(panel)) say(panel.id, panel);
        const room = panel.getBoundingClientRect().right;
        panel.querySelectorAll('table').forEach((table, i) => {
            if (wide(table)) say(`${panel.id} table ${i}`, table);
            if (table.getBoundingClientRect().right > room + 1) say(`${panel.id} out`, table);
        });
    }
    // Panels whose cells wrap rather than cut: not one cell may be cut either.
    for (const cell of document.querySelectorAll(
            '#vehicle-panel td, #groups-panel td, #tasks-panel td, #log-panel td')) {
        if (wide(cell)) say(`cell ${cell.textContent}`, cell);
    }
    return out;
}"""
"""Every visible panel, every table in it and every cell of the panels that wrap, whose
content is wider than it shows."""

FILLED = """() => ['#tasks-body', '#events-body', '#sessions-body', '#locks-body', '#nodes-body',
    '#vehicle-initiated', '#vehicle-traffic', '#groups-history']
    .filter((s) => document.querySelector(s).children.length === 0)"""
"""Tables still empty."""


@pytest.fixture(scope="module")
def served() -> Iterator[Served]:
    fleet = Fleet(config=FleetConfig(agvs=6, seed=3, task_until=0.0))
    fleet.set_speed(4.0)
    with Served(fleet) as served:
        for station in ("pick-A1-1", "pick-A2-1", "pick-A3-1"):
            served.post("/api/tasks", {"station": station})
        deadline = time.monotonic() + 30
        while not any(s["joins"] for s in served.get("/api/membership").json()):
            assert time.monotonic() < deadline, "no session gained a member"
            time.sleep(0.2)  # polling a live server, not an assertion
        yield served


def _live_session(served: Served) -> str:
    """The newest session that is live and has members now (the fleet runs on: one
    listed a moment ago may have ended since)."""
    deadline = time.monotonic() + 30
    while True:
        listed = served.get("/api/membership").json()
        live = [s for s in listed if s["ended_at"] is None and s["members"]]
        if live:
            return str(max(live, key=lambda s: s["started_at"])["id"])
        assert time.monotonic() < deadline, "no live session with members"
        time.sleep(0.2)  # polling a live server, not an assertion


def fill_panels(page: Any, served: Served) -> None:
    driving = next(
        (v for v in served.get("/api/vehicles").json() if v["task"]),
        None,
    )
    page.evaluate("id => window.__vehiclePanel.select(id)", driving["id"] if driving else "agv-01")
    for attempt in range(3):
        sid = _live_session(served)
        page.wait_for_function(
            "sid => [...document.querySelectorAll('#groups-session option')]"
            ".some(o => o.value === sid)",
            arg=sid,
            timeout=10_000,
        )
        page.select_option("#groups-session", sid)
        page.fill("#groups-definition", json.dumps({"type": "within", "distance": 1000}))
        page.click("#groups-show")
        try:
            page.wait_for_function("window.__groupsPanel.members.length > 0", timeout=5_000)
            break
        except PlaywrightTimeoutError:
            if attempt == 2:
                raise  # three live sessions in a row ended before the panel showed them
    page.wait_for_function(f"({FILLED})().length === 0", timeout=15_000)


@pytest.mark.parametrize(("width", "height"), [(1400, 900), (1920, 1080)])
def test_no_table_is_clipped(served: Served, width: int, height: int) -> None:
    with chromium_page(width=width, height=height) as (page, problems):
        load_dashboard(page, served)
        fill_panels(page, served)
        time.sleep(1.0)  # a second of live updates: rows grow and shrink as they like
        assert page.evaluate(CLIPPED) == []
    assert problems == [], problems
