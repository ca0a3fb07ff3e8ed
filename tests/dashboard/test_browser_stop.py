"""The Pause button with ``--processes``, in real headless chromium: it stops the fleet,
and the page says "stopped" only once every AGV process reports standing.

Real AGV processes on 127.0.0.1 behind a real server; every wait is bounded, and the
processes are reaped when the server stops.
"""

from __future__ import annotations

import time

import pytest

from agv_app.fleet import MeshFleet
from tests.dashboard.browser import BROWSER_MARKS, chromium_page, load_dashboard
from tests.dashboard.served import Served

pytestmark = [*BROWSER_MARKS, pytest.mark.processes]

_WATCH_STOP = """() => {
  window.__stops = [];
  const el = document.querySelector("#fleet-stop");
  new MutationObserver(() => {
    const motion = Object.values(window.__dashboard.motion());
    const standing = motion.every(([speed, held]) => speed === 0 && held === true);
    window.__stops.push([el.dataset.stop, standing, el.textContent]);
  }).observe(el, { attributes: true, childList: true, characterData: true, subtree: true });
}"""


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
