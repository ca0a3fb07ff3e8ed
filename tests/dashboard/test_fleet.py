"""The REST API over the real AGV fleet: locks and a task (the page: test_browser_fleet)."""

from __future__ import annotations

from agv_app.fleet import Fleet, FleetConfig, demo_source
from dashboard.app import create_app
from dashboard.source import FleetSource
from tests.dashboard.login import logged_in


def small_fleet() -> Fleet:
    # No random tasks: the tests create the only ones.
    return Fleet(config=FleetConfig(agvs=4, seed=3, task_until=0.0))


def test_the_fleet_is_a_fleet_source() -> None:
    source: FleetSource = demo_source(agvs=2, seed=1)
    assert isinstance(source, FleetSource)


def test_locks_and_a_task_over_rest() -> None:
    fleet = small_fleet()
    client = logged_in(create_app(fleet))
    r = client.post("/api/tasks", json={"station": "pick-A1-1"})
    assert r.status_code == 201, r.text
    task_id = r.json()["task_id"]
    for _ in range(200):
        fleet.advance(0.1)
        if any(v.task_id == task_id for v in fleet.vehicles()):
            break
    holders = [v.id for v in fleet.vehicles() if v.task_id == task_id]
    assert len(holders) == 1
    locks = {lk["vehicle"]: lk for lk in client.get("/api/locks").json()}
    assert sorted(locks) == sorted(v.id for v in fleet.vehicles())
    assert locks[holders[0]]["locked"], "a vehicle with a task locks area ahead"
    assert all(len(p) >= 3 for p in locks[holders[0]]["locked"])
    r = client.post("/api/tasks", json={"station": "parking-x"})
    assert r.status_code == 404
    metrics = client.get("/api/metrics").json()["metrics"]
    assert metrics["tasks_created"] == 1.0
    assert metrics["collisions"] == 0.0
