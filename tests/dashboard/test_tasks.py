"""``/api/tasks``: transport orders listed from the task book, read and cancelled."""

from __future__ import annotations

from typing import Any

import pytest

from agv_app.fleet import Fleet, FleetConfig
from dashboard.app import create_app
from dashboard.source import TaskBookSource
from tests.dashboard.conftest import NetworkSource, TestClient
from tests.dashboard.login import anonymous, logged_in

TASK_FIELDS = {
    "id",
    "creator",
    "source",
    "destination",
    "state",
    "vehicle",
    "created",
    "started",
    "finished",
    "waits",
}


@pytest.fixture
def fleet() -> Fleet:
    # No random tasks: the tests create the only ones.
    return Fleet(config=FleetConfig(agvs=4, seed=3, task_until=0.0))


@pytest.fixture
def fleet_client(fleet: Fleet) -> TestClient:
    return logged_in(create_app(fleet))


def create(client: TestClient, station: str = "pick-A1-1") -> str:
    r = client.post("/api/tasks", json={"station": station})
    assert r.status_code == 201, r.text
    return str(r.json()["task_id"])


def advance_until_driving(fleet: Fleet, client: TestClient, task_id: str) -> dict[str, Any]:
    for _ in range(600):
        fleet.advance(0.1)
        task = client.get(f"/api/tasks/{task_id}").json()
        if task["state"] == "driving":
            return dict(task)
    raise AssertionError(f"task {task_id} never set off: {task}")


def test_the_fleet_keeps_a_task_book(fleet: Fleet) -> None:
    assert isinstance(fleet, TaskBookSource)


def test_a_new_task_waits_at_its_station(fleet_client: TestClient) -> None:
    task_id = create(fleet_client)
    tasks = fleet_client.get("/api/tasks").json()
    assert [t["id"] for t in tasks] == [task_id]
    task = tasks[0]
    assert set(task) == TASK_FIELDS
    assert task["source"] == "pick-A1-1"
    assert task["destination"] != "pick-A1-1"
    assert task["state"] == "waiting"
    assert task["vehicle"] is None
    assert task["started"] is None
    assert task["finished"] is None
    assert fleet_client.get(f"/api/tasks/{task_id}").json() == task


def test_a_task_is_followed_until_its_vehicle_drives_it(
    fleet: Fleet, fleet_client: TestClient
) -> None:
    task_id = create(fleet_client)
    task = advance_until_driving(fleet, fleet_client, task_id)
    assert task["vehicle"] in {v.id for v in fleet.vehicles()}
    assert task["started"] is not None
    assert task["started"] >= task["created"]
    driving = fleet_client.get("/api/tasks", params={"state": "driving"}).json()
    assert [t["id"] for t in driving] == [task_id]
    assert fleet_client.get("/api/tasks", params={"state": "waiting"}).json() == []


def test_cancel_a_waiting_task(fleet: Fleet, fleet_client: TestClient) -> None:
    task_id = create(fleet_client)
    r = fleet_client.delete(f"/api/tasks/{task_id}")
    assert r.status_code == 200, r.text
    assert r.json()["state"] == "cancelled"
    assert r.json()["finished"] == pytest.approx(fleet.now)
    assert fleet.open_tasks == []
    cancelled = fleet_client.get("/api/tasks", params={"state": "cancelled"}).json()
    assert [t["id"] for t in cancelled] == [task_id]
    for _ in range(100):
        fleet.advance(0.1)
    assert fleet_client.get(f"/api/tasks/{task_id}").json()["vehicle"] is None
    again = fleet_client.delete(f"/api/tasks/{task_id}")
    assert again.status_code == 409
    assert "cancelled already" in again.json()["detail"]


def test_a_driving_task_is_not_cancelled(fleet: Fleet, fleet_client: TestClient) -> None:
    task_id = create(fleet_client)
    task = advance_until_driving(fleet, fleet_client, task_id)
    r = fleet_client.delete(f"/api/tasks/{task_id}")
    assert r.status_code == 409
    detail = r.json()["detail"]
    assert task_id in detail
    assert task["vehicle"] in detail
    assert "driving" in detail
    assert fleet_client.get(f"/api/tasks/{task_id}").json()["state"] == "driving"
    assert task_id in fleet.open_tasks


def test_the_list_keeps_the_most_recent(fleet_client: TestClient) -> None:
    ids = [create(fleet_client) for _ in range(3)]
    listed = fleet_client.get("/api/tasks", params={"limit": 2}).json()
    assert [t["id"] for t in listed] == ids[1:]


@pytest.mark.parametrize(
    ("method", "url", "params", "status"),
    [
        ("GET", "/api/tasks", {"state": "lost"}, 422),
        ("GET", "/api/tasks", {"state": "created"}, 422),
        ("GET", "/api/tasks", {"limit": "0"}, 422),
        ("GET", "/api/tasks", {"limit": "2001"}, 422),
        ("GET", "/api/tasks", {"limit": "many"}, 422),
        ("GET", "/api/tasks/task-999", {}, 404),
        ("GET", "/api/tasks/" + "x" * 129, {}, 422),
        ("DELETE", "/api/tasks/task-999", {}, 404),
        ("DELETE", "/api/tasks/" + "%00" * 3, {}, 404),
        ("DELETE", "/api/tasks/" + "x" * 129, {}, 422),
    ],
)
def test_bad_task_requests_are_refused_with_4xx(
    fleet_client: TestClient, method: str, url: str, params: dict[str, str], status: int
) -> None:
    r = fleet_client.request(method, url, params=params)
    assert r.status_code == status, r.text
    assert r.json()["detail"]


def test_cancel_needs_the_operator_token(fleet: Fleet) -> None:
    app = create_app(fleet)
    operator, viewer, stranger = logged_in(app), logged_in(app, "viewer"), anonymous(app)
    task_id = operator.post("/api/tasks", json={"station": "pick-A1-1"}).json()["task_id"]
    assert stranger.delete(f"/api/tasks/{task_id}").status_code == 401
    assert viewer.delete(f"/api/tasks/{task_id}").status_code == 403
    assert viewer.get(f"/api/tasks/{task_id}").json()["state"] == "waiting"
    assert operator.delete(f"/api/tasks/{task_id}").status_code == 200


def test_a_fleet_without_a_task_book_lists_none(client: TestClient, source: NetworkSource) -> None:
    assert not isinstance(source, TaskBookSource)
    assert client.get("/api/tasks").json() == []
    assert client.get("/api/tasks/task-1").status_code == 404
    assert client.delete("/api/tasks/task-1").status_code == 404


def test_a_task_past_the_fleets_backlog_is_refused_with_503(
    fleet: Fleet, fleet_client: TestClient
) -> None:
    fleet.desk.backlog = 2
    create(fleet_client)
    create(fleet_client)
    r = fleet_client.post("/api/tasks", json={"station": "pick-A1-1"})
    assert r.status_code == 503
    assert r.headers["retry-after"] == "10"
    assert "2 tasks are open, as many as the task desk holds" in r.json()["detail"]
    assert fleet.desk.refused == 1
