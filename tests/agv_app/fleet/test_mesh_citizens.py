"""AGV processes as full citizens of the dashboard's API, and a killed one's alarm.

Real processes on 127.0.0.1, served through the dashboard app; every wait is bounded
and every child is reaped when the app stops.
"""

from __future__ import annotations

import os
import signal
import time
from collections.abc import Callable
from typing import Any

import pytest

from agv_app.fleet import OBSERVER_ID, MeshFleet
from dashboard.app import create_app
from tests.dashboard.login import logged_in

pytestmark = pytest.mark.processes

PICK = "pick-A3-1"


def wait_for(what: str, probe: Callable[[], Any], timeout_s: float, fleet: MeshFleet) -> Any:
    """Poll ``probe`` every 0.1 s until it answers something truthy (bounded)."""
    deadline = time.monotonic() + timeout_s
    while True:
        found = probe()
        if found:
            return found
        if time.monotonic() >= deadline:
            pytest.fail(f"{what} within {timeout_s} s; logs: {fleet.child_logs()}")
        time.sleep(0.1)


def test_agvs_are_nodes_vehicles_and_session_initiators_of_the_api() -> None:
    fleet = MeshFleet(agvs=3, seed=4, task_interval=None, run_seconds=100.0)
    agvs = fleet.agv_ids
    with logged_in(create_app(fleet)) as client:

        def listed() -> bool:
            ids = [n["id"] for n in client.get("/api/nodes").json()]
            return set(agvs) <= set(ids)

        wait_for("every AGV listed in /api/nodes", listed, 40, fleet)
        nodes = {n["id"]: n for n in client.get("/api/nodes").json()}
        assert {OBSERVER_ID, *agvs} <= set(nodes)
        assert nodes[agvs[0]]["properties"]["kind"] == "agv"
        assert "sessions" not in nodes[agvs[0]]["properties"]

        r = client.post("/api/tasks", json={"station": PICK})
        assert r.status_code == 201, r.text
        task = r.json()["task_id"]

        def driving() -> dict[str, Any] | None:
            return next(
                (
                    v
                    for v in client.get("/api/vehicles").json()
                    if v["task"] == task and v["status"] != "idle"
                ),
                None,
            )

        taker = wait_for("a vehicle setting off with the task", driving, 30, fleet)["id"]

        def agv_session() -> list[dict[str, Any]]:
            return [s for s in client.get("/api/sessions").json() if s["node"] in agvs]

        sessions = wait_for("a session of an AGV in /api/sessions", agv_session, 30, fleet)
        session = sessions[0]
        assert isinstance(session["definition"]["type"], str), "a declarative definition"
        assert session["via_api"] is False
        assert 0.0 <= session["started_at"] <= fleet.now + 1.0, "in the fleet's time"
        detail = client.get(f"/api/sessions/{session['id'].replace('#', '%23')}")
        assert detail.status_code == 200, detail.text

        node = client.get(f"/api/nodes/{taker}")
        assert node.status_code == 200, node.text
        body = node.json()
        assert body["properties"]["task"] == task
        assert body["stats"]["sent"], "its traffic by kind, as it published it"
        assert body["messages"] > 0
        assert client.get(f"/api/vehicles/{taker}").json()["task"] == task
        locks = {lock["vehicle"]: lock for lock in client.get("/api/locks").json()}
        assert set(locks) == set(agvs)
        assert all(lock["locked"] for lock in locks.values())
        # Its tuplespace, read from its process by the observer (objectplaces.space_pages).
        space = client.get(f"/api/nodes/{taker}/space", params={"limit": 100})
        assert space.status_code == 200, space.text
        held = space.json()
        assert held["node"] == taker
        assert held["total"] >= len(held["tuples"]) >= 1
        assert "lock" in {t[0] for t in held["tuples"]}, held

        def route() -> list[Any]:
            reply = client.get(f"/api/vehicles/{taker}/detail")
            assert reply.status_code == 200, reply.text
            found: list[Any] = reply.json().get("route", [])
            return found

        assert len(wait_for("the route ahead of the taker", route, 10, fleet)) >= 2

        refused = client.post(
            "/api/sessions",
            json={
                "node": taker,
                "role": "poll",
                "participant_role": "poll-responder",
                "definition": {"type": "within", "distance": 30},
                "params": {"property": "status"},
            },
        )
        assert refused.status_code == 422, refused.text
        assert "own process" in refused.json()["detail"]
        within = '{"type": "within", "distance": 5}'
        view = client.get("/api/groups/view", params={"node": taker, "definition": within})
        assert view.status_code == 422, view.text
        assert client.get("/api/nodes/agv-99").status_code == 404
        assert client.get("/api/vehicles/agv-99").status_code == 404
    assert not any(code is None for code in fleet.exit_codes().values())


def test_an_agv_process_killed_with_sigkill_raises_an_alarm_within_10_s() -> None:
    fleet = MeshFleet(agvs=2, seed=6, task_interval=None, run_seconds=100.0)
    with logged_in(create_app(fleet)) as client:

        def both_heard() -> bool:
            return len(client.get("/api/vehicles").json()) == 2

        wait_for("both AGVs heard", both_heard, 40, fleet)
        assert client.get("/api/metrics").json()["metrics"]["agvs"] == 2
        victim, survivor = fleet.agv_ids
        os.kill(fleet.pids()[0], signal.SIGKILL)
        killed_at = time.monotonic()

        def alarm() -> list[dict[str, Any]]:
            alarms = client.get("/api/events", params={"severity": "alarm"}).json()["alarms"]
            return [a for a in alarms if a["key"] == f"failed:{victim}"]

        raised = wait_for("the alarm of the killed AGV", alarm, 10, fleet)
        assert time.monotonic() - killed_at <= 10.0
        assert raised[0]["severity"] == "alarm"
        assert raised[0]["source"] == victim
        metrics = client.get("/api/metrics").json()["metrics"]
        assert metrics["agvs"] == 1
        assert metrics["agvs_failed"] == 1
        vehicles = {v["id"]: v for v in client.get("/api/vehicles").json()}
        assert vehicles[victim]["status"] == "failed"
        assert vehicles[victim]["locked"] == []
        assert vehicles[survivor]["status"] != "failed"
        assert victim not in [n["id"] for n in client.get("/api/nodes").json()]
        assert client.get(f"/api/nodes/{victim}").status_code == 404
        events = client.get("/api/events").json()["events"]
        assert any(e["source"] == victim and e["severity"] == "alarm" for e in events)
        time.sleep(4.0)  # past the observer's failure timeout: the alarm stays
        assert alarm(), "the wreck's alarm stays until it recovers"
    assert fleet.exit_codes()[victim] == -signal.SIGKILL
    assert fleet.exit_codes()[survivor] == 0
