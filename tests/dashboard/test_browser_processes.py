"""``--processes`` in real headless chromium: the AGVs' sessions are listed, and a
killed AGV process raises its alarm within 10 s.

Real AGV processes on 127.0.0.1 behind a real server; every wait is bounded, and the
processes are reaped when the server stops.
"""

from __future__ import annotations

import os
import signal
import time

import pytest

from agv_app.fleet import MeshFleet
from tests.dashboard.browser import BROWSER_MARKS, chromium_page, load_dashboard
from tests.dashboard.served import Served

pytestmark = [*BROWSER_MARKS, pytest.mark.processes]


def test_agv_sessions_show_and_a_process_killed_with_sigkill_raises_its_alarm() -> None:
    fleet = MeshFleet(agvs=2, seed=8, task_interval=None, run_seconds=100.0)
    with Served(fleet) as served, chromium_page() as (page, problems):
        load_dashboard(page, served)
        page.wait_for_function(
            "Object.keys(window.__dashboard.vehicles()).length === 2", timeout=40_000
        )
        page.locator("#nodes-panel tr[data-node-id='agv-01']").wait_for(timeout=10_000)
        r = served.post("/api/tasks", {"station": "pick-A3-1"})
        assert r.status_code == 201, r.text
        # The AGV that takes it asks its neighbours for floor: its sessions are listed.
        page.locator("#sessions-panel tr[data-session-id^='agv-']").first.wait_for(timeout=30_000)
        victim = fleet.agv_ids[0]
        os.kill(fleet.pids()[0], signal.SIGKILL)
        killed_at = time.monotonic()
        alarm = page.locator(f"#alarms li[data-alarm-key='failed:{victim}']")
        alarm.wait_for(timeout=10_000)
        assert time.monotonic() - killed_at <= 10.0
        assert alarm.text_content().endswith(f"{victim} failed")
        page.wait_for_function(
            f"window.__dashboard.vehicles()[{victim!r}][2] === 'failed'", timeout=5_000
        )
        metrics = served.get("/api/metrics").json()["metrics"]
        assert metrics["agvs"] == 1
        assert metrics["agvs_failed"] == 1
        assert problems == [], problems
    assert fleet.exit_codes()[victim] == -signal.SIGKILL
