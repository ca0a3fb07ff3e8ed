"""Stopping in real headless chromium: the Pause button with ``--processes`` stops the
fleet, and the page says "stopped" only once every AGV process reports standing; the
vehicle panel's buttons stop, resume and take out of service one AGV of the simulated
fleet.

Real AGV processes on 127.0.0.1 behind a real server; every wait is bounded, and the
processes are reaped when the server stops.
"""

from __future__ import annotations

import time

import pytest

from agv_app.fleet import Fleet, FleetConfig, MeshFleet
from tests.dashboard.browser import BROWSER_MARKS, chromium_page, load_dashboard
from tests.dashboard.served import Served

pytestmark = BROWSER_MARKS

_WATCH_STOP = """() => {
  window.__stops = [];
  const el = document.querySelector("#fleet-stop");
  new MutationObserver(() => {
    const motion = Object.values(window.__dashboard.motion());
    const standing = motion.every(([speed, held]) => speed === 0 && held === true);
    window.__stops.push([el.dataset.stop, standing, el.textContent]);
  }).observe(el, { attributes: true, childList: true, characterData: true, subtree: true });
}"""


@pytest.mark.processes
def test_pause_stops_every_agv_process_and_the_page_says_so_only_once_they_stand() -> None:
    fleet = MeshFleet(agvs=2, seed=8, task_interval=None, run_seconds=120.0)
    with Served(fleet) as served, chromium_page() as (page, problems):
        load_dashboard(page, served)
        page.wait_for_function(
            "Object.keys(window.__dashboard.motion()).length === 2", timeout=40_000
        )
        r = served.post("/api/tasks", {"station": "pick-A3-1"})
        assert r.status_code == 201, r.text
        page.wait_for_function(
            "Object.values(window.__dashboard.motion()).some(([speed]) => speed > 0)",
            timeout=40_000,
        )
        page.evaluate(_WATCH_STOP)
        pressed = time.monotonic()
        page.get_by_test_id("btn-pause").click()
        page.wait_for_function(
            "document.querySelector('#fleet-stop').dataset.stop === 'stopped'", timeout=20_000
        )
        took = time.monotonic() - pressed
        assert page.get_by_test_id("fleet-stop").text_content() == (
            "fleet stopped: every vehicle stands"
        )
        seen = page.evaluate("window.__stops")
        assert seen, "the page showed the stop"
        assert all(standing for stop, standing, _ in seen if stop == "stopped"), seen
        motion = page.evaluate("window.__dashboard.motion()")
        assert motion == {"agv-01": [0, True], "agv-02": [0, True]}
        answer = served.get("/api/fleet/stop").json()
        assert answer["state"] == "stopped"
        assert all(v["speed"] == 0.0 and v["held"] for v in answer["vehicles"])
        assert took < 20.0
        events = served.get("/api/events").json()["events"]
        assert any(e["text"].startswith("fleet paused") for e in events)

        page.get_by_test_id("btn-resume").click()
        page.wait_for_function(
            "document.querySelector('#fleet-stop').dataset.stop === 'running'", timeout=20_000
        )
        page.wait_for_function(
            "Object.values(window.__dashboard.motion()).every(([, held]) => held === false)",
            timeout=20_000,
        )
        assert problems == [], problems


def test_the_vehicle_panel_stops_and_resumes_an_agv_and_shows_what_it_reports() -> None:
    fleet = Fleet(config=FleetConfig(agvs=3, seed=3, task_until=0.0))
    with Served(fleet) as served, chromium_page() as (page, problems):
        load_dashboard(page, served)
        page.wait_for_function("window.__vehiclePanel !== undefined", timeout=10_000)
        page.evaluate("window.__vehiclePanel.select('agv-02')")
        motion = page.locator("#vehicle-facts dd[data-fact=motion]")
        motion.wait_for(timeout=10_000)
        page.get_by_test_id("vehicle-stop").click()
        page.wait_for_function(
            "document.querySelector('#vehicle-facts dd[data-fact=motion]')"
            ".textContent.includes('held')",
            timeout=10_000,
        )
        assert motion.text_content() == "0.00 m/s, held (stopped by the operator)"
        events = served.get("/api/events").json()["events"]
        assert any(e["text"].startswith("agv-02 stop asked by operator") for e in events)
        page.get_by_test_id("vehicle-out").click()
        page.wait_for_function(
            "document.querySelector('#vehicle-facts dd[data-fact=service]')"
            ".textContent === 'out of service'",
            timeout=10_000,
        )
        page.get_by_test_id("vehicle-resume").click()
        page.get_by_test_id("vehicle-in").click()
        page.wait_for_function(
            "document.querySelector('#vehicle-facts dd[data-fact=motion]')"
            ".textContent === '0.00 m/s'"
            " && document.querySelector('#vehicle-facts dd[data-fact=service]')"
            ".textContent === 'in service'",
            timeout=10_000,
        )
        page.get_by_test_id("vehicle-home").click()  # at home already: asked and logged
        page.wait_for_function(
            "document.querySelector('#vehicle-status').textContent === 'agv-02: send home asked'",
            timeout=10_000,
        )
        events = served.get("/api/events").json()["events"]
        assert any(e["text"].startswith("agv-02 sent home, asked by operator") for e in events)
        # Its tuplespace, where its locks live, opened on the card.
        page.locator("#vehicle-space-box summary").click()
        page.locator("#vehicle-space li").first.wait_for(timeout=10_000)
        total = served.get("/api/nodes/agv-02/space").json()["total"]
        assert page.locator("#vehicle-space-note").text_content() == f"{total} tuples"
        assert page.locator("#vehicle-space li").count() == min(total, 50)
        assert problems == [], problems
