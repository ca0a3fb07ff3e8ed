"""The page in real headless chromium, served by uvicorn over real middleware nodes."""

from __future__ import annotations

import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from tests.dashboard.browser import BROWSER_MARKS, chromium_page, load_dashboard
from tests.dashboard.conftest import NetworkSource
from tests.dashboard.served import Served

pytestmark = BROWSER_MARKS


@pytest.fixture
def served(source: NetworkSource) -> Iterator[Served]:
    with Served(source) as s:
        yield s


@pytest.fixture
def page(served: Served, tmp_path: Path) -> Iterator[Any]:
    with chromium_page() as (page, problems):
        page.on("requestfailed", lambda r: problems.append(f"request failed: {r.url}"))
        load_dashboard(page, served)
        yield page
        page.screenshot(path=str(tmp_path / "dashboard.png"))
    assert problems == [], problems


def test_page_loads_and_draws_without_errors(page: Any) -> None:
    page.wait_for_function("window.__dashboard.frames > 30", timeout=10_000)
    assert page.locator("#conn-status").text_content() == "live"
    stations = page.evaluate("window.__dashboard.stationIds()")
    assert "pick-A1-1" in stations
    nodes = page.locator("#nodes-panel tr[data-node-id]")
    page.wait_for_function(
        "document.querySelectorAll('#nodes-panel tr[data-node-id]').length === 4"
    )
    assert nodes.first.get_attribute("data-node-id") == "agv-1"


def test_session_started_over_rest_shows_in_the_panel(page: Any, served: Served) -> None:
    r = served.post(
        "/api/sessions",
        {
            "node": "agv-1",
            "role": "poll",
            "definition": {"type": "within", "distance": 10.0},
            "participant_role": "poll-responder",
            "params": {"property": "status"},
        },
    )
    assert r.status_code == 201, r.text
    sid = r.json()["id"]
    row = page.locator(f'#sessions-panel tr[data-session-id="{sid}"]')
    row.wait_for(timeout=5_000)
    members = row.locator("td[data-members]")
    page.wait_for_function(
        'sid => (document.querySelector(`#sessions-panel tr[data-session-id="${sid}"] '
        "td[data-members]`) || {}).getAttribute?.('data-members') === 'agv-2'",
        arg=sid,
        timeout=5_000,
    )
    assert members.get_attribute("data-members") == "agv-2"
    assert "poll" in row.text_content()
    row.click()
    detail = page.locator("#session-detail")
    page.wait_for_function(
        "document.querySelector('#session-detail').textContent.includes('answers')",
        timeout=5_000,
    )
    assert '"agv-2": "idle"' in detail.text_content()
    row.click()
    assert page.locator("#session-detail").is_hidden()
    served.delete(f"/api/sessions/{sid.replace('#', '%23')}")
    row.wait_for(state="detached", timeout=5_000)


def test_clicking_a_station_creates_a_task(page: Any, source: NetworkSource) -> None:
    pos = page.evaluate("window.__dashboard.stationScreenPosition('pick-A1-1')")
    assert pos is not None
    page.mouse.click(pos["x"], pos["y"])
    page.wait_for_function("window.__dashboard.lastTask !== null", timeout=5_000)
    assert page.evaluate("window.__dashboard.lastTask") == {"id": "task-1", "station": "pick-A1-1"}
    assert "task-1 created at pick-A1-1" in page.locator("#control-status").text_content()
    assert source.tasks == ["pick-A1-1"]


def test_pause_and_speed_controls(page: Any, served: Served) -> None:
    page.click("#btn-pause")
    page.wait_for_function("document.querySelector('#sim-clock').textContent.includes('paused')")
    assert served.source.paused
    page.select_option("#speed", "5")
    deadline = time.monotonic() + 5
    while served.source.speed != 5.0:
        assert time.monotonic() < deadline
        time.sleep(0.05)
    page.click("#btn-resume")
    page.wait_for_function("!document.querySelector('#sim-clock').textContent.includes('paused')")
