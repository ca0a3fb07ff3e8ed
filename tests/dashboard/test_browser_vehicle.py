"""The vehicle panel in real headless chromium over the real AGV fleet: click an AGV,
see its status, sessions and traffic, and its route drawn on the map as it moves."""

from __future__ import annotations

import time
from collections.abc import Iterator
from typing import Any

import pytest

from agv_app.fleet import Fleet, FleetConfig
from tests.dashboard.browser import BROWSER_MARKS, chromium_page, load_dashboard
from tests.dashboard.canvas import LEGEND_RGB, PIXEL
from tests.dashboard.served import Served, wait_for

pytestmark = BROWSER_MARKS


@pytest.fixture(scope="module")
def fleet_page() -> Iterator[tuple[Any, Served]]:
    # No random tasks: the test creates the one it follows; paused until it does.
    fleet = Fleet(config=FleetConfig(agvs=4, seed=3, task_until=0.0))
    fleet.set_speed(4.0)
    fleet.pause()
    with Served(fleet) as served:
        with chromium_page() as (page, problems):
            load_dashboard(page, served)
            yield page, served
        assert problems == [], problems


def post(served: Served, path: str, body: dict[str, Any] | None = None) -> Any:
    r = served.post(path, body)
    assert r.status_code < 300, r.text
    return r.json()


def test_an_agv_over_its_parking_station_wins_the_hover(fleet_page: tuple[Any, Served]) -> None:
    page, _ = fleet_page
    # At rest every AGV stands on its home station: the AGV is what a click picks.
    vehicles = page.evaluate("window.__dashboard.vehicles()")
    agv = sorted(vehicles)[0]
    pos = page.evaluate(f"window.__dashboard.vehicleScreenPosition('{agv}')")
    under = page.evaluate(
        """([x, y]) => window.__dashboard.stationIds().filter((id) => {
            const p = window.__dashboard.stationScreenPosition(id);
            return Math.hypot(p.x - x, p.y - y) <= 12;
        })""",
        [pos["x"], pos["y"]],
    )
    assert under, f"{agv} stands on a station"
    page.mouse.move(pos["x"], pos["y"])
    tooltip = page.locator("#tooltip")
    page.wait_for_function("!document.getElementById('tooltip').hidden", timeout=5_000)
    text = tooltip.text_content()
    assert text.startswith(agv), text
    assert "click: details and route" in text
    # A pick station says what a click does; a parking station with no AGV says no task.
    pick = page.evaluate("window.__dashboard.stationScreenPosition('pick-A1-1')")
    page.mouse.move(pick["x"], pick["y"])
    page.wait_for_function(
        "document.getElementById('tooltip').textContent.startsWith('pick-A1-1')", timeout=5_000
    )
    assert "click: add a transport task here" in tooltip.text_content()
    # A drop station takes no task from a click, and its tooltip says so.
    drop = page.evaluate("window.__dashboard.stationScreenPosition('drop-A1-3')")
    page.mouse.move(drop["x"], drop["y"])
    page.wait_for_function(
        "document.getElementById('tooltip').textContent.startsWith('drop-A1-3')", timeout=5_000
    )
    assert "no tasks start here" in tooltip.text_content()
    page.mouse.click(drop["x"], drop["y"])
    # A request the click sent would have been answered well within this.
    page.wait_for_timeout(500)
    assert page.evaluate("window.__dashboard.lastTask") is None
    assert page.locator("#control-status").text_content() == ""
    page.mouse.move(1, 1)


def test_the_panel_shows_a_moving_agvs_route(fleet_page: tuple[Any, Served]) -> None:
    page, served = fleet_page
    task_id = post(served, "/api/tasks", {"station": "pick-A1-1"})["task_id"]
    post(served, "/api/sim/resume")

    def driving() -> str | None:
        vehicles = page.evaluate("window.__dashboard.vehicles()")
        return next(
            (v for v, (_, _, s, t) in vehicles.items() if t == task_id and s == "driving"), None
        )

    agv = wait_for(driving, 30.0, f"an AGV drives for {task_id}")
    # Stand the fleet still for the click, so the pointer finds the AGV where it is drawn.
    post(served, "/api/sim/pause")
    page.wait_for_function("document.getElementById('btn-pause').disabled", timeout=5_000)
    time.sleep(0.3)  # the last delta's glide (at most 0.2 s) ends: no assertion waits on it
    pos = page.evaluate(f"window.__dashboard.vehicleScreenPosition('{agv}')")
    page.mouse.click(pos["x"], pos["y"])
    page.wait_for_function(
        "window.__vehiclePanel.detail && window.__vehiclePanel.detail.route.length >= 2"
        " && window.__vehiclePanel.drawnPoints >= 2",
        timeout=5_000,
    )
    assert page.evaluate("window.__vehiclePanel.selected") == agv
    assert page.locator("#vehicle-panel").is_visible()
    assert page.locator("#vehicle-id").text_content() == agv
    assert page.locator("#vehicle-facts dd[data-fact=task]").text_content() == task_id
    assert page.locator("#vehicle-facts dd[data-fact=route]").text_content().endswith(")")
    assert "frames" in page.locator("#vehicle-facts dd[data-fact=sent]").text_content()
    assert page.locator("#vehicle-facts dd[data-fact=battery]").text_content() == "\u2013"
    assert page.locator("#vehicle-traffic tr").count() > 0
    assert page.evaluate("window.__dashboard.lastTask") is None, "an AGV click adds no task"

    # The route's end is marked on the canvas in the colour the legend gives the route.
    detail = page.evaluate("window.__vehiclePanel.detail")
    end = page.evaluate("([x, y]) => window.__dashboard.screenPosition(x, y)", detail["route"][-1])
    route_rgb = page.evaluate(LEGEND_RGB, "#legend .sw.route")
    assert route_rgb == [198, 255, 0]
    assert page.evaluate(PIXEL, [end["x"], end["y"]]) == route_rgb

    # Moving on, the route left shrinks.
    left = detail["route_length"]
    post(served, "/api/sim/resume")
    page.wait_for_function(
        f"window.__vehiclePanel.detail && window.__vehiclePanel.detail.route_length < {left} - 1",
        timeout=30_000,
    )
    assert page.evaluate("window.__vehiclePanel.drawnPoints") >= 2

    page.click("#vehicle-close")
    assert page.locator("#vehicle-panel").is_hidden()
    page.wait_for_function("window.__vehiclePanel.drawnPoints === 0", timeout=5_000)


def test_controls_show_the_true_state_and_messages_clear(fleet_page: tuple[Any, Served]) -> None:
    page, served = fleet_page
    post(served, "/api/sim/pause")  # from outside the page: the page follows
    page.wait_for_function("document.getElementById('btn-pause').disabled", timeout=5_000)
    assert page.locator("#btn-resume").is_enabled()
    page.click("#btn-resume")
    page.wait_for_function("document.getElementById('btn-resume').disabled", timeout=5_000)
    assert page.locator("#btn-pause").is_enabled()
    assert not served.source.paused
    assert page.locator("#control-status").text_content().startswith("fleet running")
    page.wait_for_function(
        "document.getElementById('control-status').textContent === ''", timeout=10_000
    )
