"""The groups panel in real headless chromium over the real AGV fleet: a session's
members and history of joins and leaves; a typed definition's live group on the map."""

from __future__ import annotations

import json
from collections.abc import Iterator
from typing import Any

import pytest

from agv_app.fleet import Fleet, FleetConfig
from agv_app.tasks import BASE_ID
from tests.dashboard.browser import BROWSER_MARKS, chromium_page, load_dashboard
from tests.dashboard.canvas import LEGEND_BORDER_RGB, PIXEL
from tests.dashboard.served import Served, wait_for

pytestmark = BROWSER_MARKS


@pytest.fixture(scope="module")
def groups_page() -> Iterator[tuple[Any, Served]]:
    fleet = Fleet(config=FleetConfig(agvs=4, seed=3, task_until=0.0))
    fleet.set_speed(4.0)
    with Served(fleet) as served:
        with chromium_page() as (page, problems):
            load_dashboard(page, served)
            yield page, served
        # Chromium logs as failed resources a refused definition (422) and the detail of
        # a clicked session that ended before the page asked for it (404).
        assert [p for p in problems if "422" not in p and "404" not in p] == [], problems


def test_a_sessions_members_and_history(groups_page: tuple[Any, Served]) -> None:
    page, served = groups_page
    served.post("/api/tasks", {"station": "pick-A1-1"})

    def a_session_with_joins() -> str | None:
        listed = served.get("/api/membership").json()
        return next((s["id"] for s in listed if s["joins"] > 0), None)

    sid = wait_for(a_session_with_joins, 30.0, "a session gains a member")
    page.wait_for_function(
        "sid => [...document.querySelectorAll('#groups-session option')]"
        ".some(o => o.value === sid)",
        arg=sid,
        timeout=5_000,
    )
    page.select_option("#groups-session", sid)
    page.wait_for_function(
        "sid => window.__groupsPanel.history && window.__groupsPanel.history.id === sid",
        arg=sid,
        timeout=5_000,
    )
    history = page.evaluate("window.__groupsPanel.history")
    joined = [c["node"] for c in history["changes"] if c["change"] == "joined"]
    assert joined
    page.wait_for_function(
        "document.querySelectorAll('#groups-history tr[data-change]').length > 0", timeout=5_000
    )
    rows = page.locator("#groups-history tr[data-change=joined]")
    assert rows.count() >= 1
    note = page.locator("#groups-session-note").text_content()
    assert history["node"] in note
    assert f"{history['joins']} joins" in note

    # A click on a live session in the sessions panel picks it here as well. The table is
    # redrawn many times a second, so the row's id is read and the row clicked in one go:
    # a row that moved in between would pick another session.
    page.locator("#sessions-panel tr[data-session-id]").first.wait_for(timeout=10_000)
    live = page.evaluate(
        "() => { const row = document.querySelector('#sessions-panel tr[data-session-id]');"
        " row.click(); return row.dataset.sessionId; }"
    )
    page.wait_for_function(
        "sid => window.__groupsPanel.history && window.__groupsPanel.history.id === sid",
        arg=live,
        timeout=5_000,
    )
    assert page.locator("#groups-session").input_value() == live


def test_a_typed_definition_is_shown_live_on_the_map(groups_page: tuple[Any, Served]) -> None:
    page, served = groups_page
    page.wait_for_function(
        "[...document.querySelectorAll('#groups-node option')].some(o => o.value === 'agv-01')",
        timeout=10_000,
    )
    page.select_option("#groups-node", "agv-01")
    # Every template is a definition the server takes.
    for kind in ("circles_overlap", "within", "near", "property_equals", "and", "or"):
        page.select_option("#groups-template", kind)
        assert json.loads(page.locator("#groups-definition").input_value())["type"] == kind
    definition = {"type": "within", "distance": 1000}
    page.fill("#groups-definition", json.dumps(definition))
    page.click("#groups-show")
    expected = served.get(
        "/api/groups/view", {"node": "agv-01", "definition": json.dumps(definition)}
    ).json()["members"]
    assert len(expected) >= 3, "the other AGVs and the transport base are within 1 km"
    page.wait_for_function("window.__groupsPanel.members.length > 0", timeout=5_000)
    assert set(page.evaluate("window.__groupsPanel.members")) == set(expected)
    page.wait_for_function("window.__groupsPanel.drawn >= 3", timeout=5_000)
    # A member standing still (the transport base) is ringed in the legend's colour.
    assert BASE_ID in expected
    base = served.get(f"/api/nodes/{BASE_ID}").json()
    at = page.evaluate(
        "([x, y]) => window.__dashboard.screenPosition(x, y)", base["properties"]["position"]
    )
    ring = page.evaluate(LEGEND_BORDER_RGB, "#legend .sw.group")
    pixel = page.evaluate(PIXEL, [at["x"] + 14, at["y"]])
    # Within a few levels of the legend's colour: the ring's edge is antialiased.
    assert max(abs(p - r) for p, r in zip(pixel, ring, strict=True)) <= 8, (pixel, ring)
    status = page.locator("#groups-status")
    assert "in the group from agv-01" in status.text_content()
    assert status.get_attribute("class") == "status"

    # Not JSON, then refused by the server: each says why; a good one clears the error.
    page.fill("#groups-definition", "{bad")
    page.click("#groups-show")
    assert "not JSON" in status.text_content()
    assert "error" in status.get_attribute("class")
    assert page.evaluate("window.__groupsPanel.members") == []
    page.fill("#groups-definition", '{"type": "within"}')
    page.click("#groups-show")
    page.wait_for_function(
        "document.getElementById('groups-status').textContent.includes('distance')",
        timeout=5_000,
    )
    assert page.evaluate("window.__groupsPanel.members") == []
    page.fill("#groups-definition", '{"type": "property_equals", "name": "kind", "value": "agv"}')
    page.click("#groups-show")
    page.wait_for_function(
        "document.getElementById('groups-status').className === 'status'"
        " && window.__groupsPanel.members.length > 0",
        timeout=5_000,
    )
    assert all(m.startswith("agv") for m in page.evaluate("window.__groupsPanel.members"))
    page.click("#groups-clear")
    page.wait_for_function("window.__groupsPanel.drawn === 0", timeout=5_000)
    assert status.text_content() == ""
