"""Stopping and resuming vehicles over REST, on the real simulated fleet: the operator
alone, every change in the event log with who asked, the answers as the vehicles
report (the process fleet: tests/agv_app/fleet/test_mesh_holding.py)."""

from __future__ import annotations

from typing import Any

import pytest

from agv_app.fleet import Fleet, FleetConfig
from dashboard.app import create_app
from tests.dashboard.login import TestClient, anonymous, logged_in

FOREIGN = "http://127.0.0.1:9999"


def _fleet() -> Fleet:
    return Fleet(config=FleetConfig(agvs=4, seed=3, task_until=0.0))


def _moving(fleet: Fleet, client: TestClient) -> str:
    """Create a task and advance until a vehicle drives fast; its id."""
    assert client.post("/api/tasks", json={"station": "pick-A1-1"}).status_code == 201
    for _ in range(3000):
        fleet.advance(fleet.config.dt)
        fast = [v for v in fleet.vehicles() if v.speed_m_s > 0.5]
        if fast:
            return fast[0].id
    pytest.fail("no vehicle ever drove")


def _events(client: TestClient) -> list[dict[str, Any]]:
    events: list[dict[str, Any]] = client.get("/api/events").json()["events"]
    return events


def test_only_the_operator_stops_and_only_from_the_page_s_origin() -> None:
    app = create_app(_fleet())
    body = {"reason": "person on the floor"}
    assert anonymous(app).post("/api/fleet/stop", json=body).status_code == 401
    assert logged_in(app, "viewer").post("/api/fleet/stop", json=body).status_code == 403
    assert logged_in(app, "viewer").post("/api/vehicles/agv-01/stop", json={}).status_code == 403
    operator = logged_in(app)
    r = operator.post("/api/fleet/stop", json=body, headers={"Origin": FOREIGN})
    assert r.status_code == 403
    assert (
        operator.post("/api/vehicles/agv-01/stop", json={}, headers={"Origin": FOREIGN}).status_code
        == 403
    )
    assert operator.get("/api/fleet/stop").json()["asked"] is False, "nothing was applied"
    assert logged_in(app, "viewer").get("/api/fleet/stop").status_code == 200


def test_a_fleet_stop_answers_stopping_until_every_vehicle_stands_and_is_logged() -> None:
    fleet = _fleet()
    client = logged_in(create_app(fleet))
    driving = _moving(fleet, client)

    r = client.post("/api/fleet/stop", json={"reason": "person on the floor"})
    assert r.status_code == 200, r.text
    answer = r.json()
    assert answer["asked"] is True
    assert answer["state"] == "stopping", "a vehicle still brakes: not stopped yet"
    assert driving in answer["moving"]
    assert client.get("/api/metrics").json()["sim"]["stop"] == "stopping"
    text = next(e["text"] for e in reversed(_events(client)) if e["source"] == "fleet")
    assert text == "fleet stop asked by operator at testclient: person on the floor"

    braking_s = fleet.spec.max_speed_m_s / fleet.spec.max_accel_m_s2
    fleet.advance(braking_s + fleet.config.dt)
    answer = client.get("/api/fleet/stop").json()
    assert answer["state"] == "stopped"
    assert answer["moving"] == []
    assert {(v["speed"], v["held"], v["status"]) for v in answer["vehicles"]} == {
        (0.0, True, "stopped")
    }
    listed = client.get("/api/vehicles").json()
    assert {(v["speed"], v["held"]) for v in listed} == {(0.0, True)}
    assert client.get("/api/metrics").json()["sim"]["stop"] == "stopped"

    r = client.post("/api/fleet/resume", json={})
    assert r.json()["state"] == "running"
    assert not any(v["asked"] for v in r.json()["vehicles"])
    fleet.advance(5.0)
    assert any(v.speed_m_s > 0 for v in fleet.vehicles()), "the order goes on"
    assert (
        _events(client)[-1]["text"]
        == "fleet resume asked by operator at testclient: asked over REST"
    )


def test_one_vehicle_stops_and_resumes_and_an_unknown_one_is_named() -> None:
    fleet = _fleet()
    client = logged_in(create_app(fleet))
    driving = _moving(fleet, client)

    r = client.post(f"/api/vehicles/{driving}/stop", json={"reason": "check the load"})
    assert r.status_code == 200, r.text
    assert r.json()["asked"] is True
    assert r.json()["status"] == "stopping"
    assert r.json()["speed"] > 0, "it reports braking, not what was asked"
    fleet.advance(10.0)
    shown = client.get(f"/api/vehicles/{driving}").json()
    assert (shown["status"], shown["speed"], shown["held"]) == ("stopped", 0.0, True)
    event = _events(client)[-1]
    assert event["source"] == driving
    assert event["text"] == f"{driving} stop asked by operator at testclient: check the load"
    others = [v for v in client.get("/api/fleet/stop").json()["vehicles"] if v["id"] != driving]
    assert not any(v["asked"] for v in others)

    client.post("/api/fleet/stop", json={})
    r = client.post(f"/api/vehicles/{driving}/resume", json={})
    assert r.status_code == 409
    assert "resume the fleet first" in r.json()["detail"]
    client.post("/api/fleet/resume", json={})
    assert client.get(f"/api/vehicles/{driving}").json()["held"] is True, "stopped on its own"
    r = client.post(f"/api/vehicles/{driving}/resume", json={})
    assert r.status_code == 200
    assert r.json()["asked"] is False

    r = client.post("/api/vehicles/agv-99/stop", json={})
    assert r.status_code == 404
    assert r.json()["detail"] == "unknown vehicle 'agv-99' (known: agv-01, agv-02, agv-03, agv-04)"
    assert client.post("/api/vehicles/agv-99/resume", json={}).status_code == 404
    assert client.post(f"/api/vehicles/{driving}/stop", json={"reason": ""}).status_code == 422
    assert client.post(f"/api/vehicles/{driving}/stop", json={"why": "x"}).status_code == 422


def test_a_fleet_that_cannot_stop_says_so() -> None:
    from tests.dashboard.conftest import NetworkSource

    client = logged_in(create_app(NetworkSource()))
    r = client.post("/api/fleet/stop", json={})
    assert r.status_code == 409
    assert r.json()["detail"] == "this fleet cannot stop its vehicles"
    assert client.get("/api/metrics").json()["sim"]["stop"] == "running"


def test_a_vehicle_goes_out_of_service_and_back_over_rest() -> None:
    fleet = _fleet()
    app = create_app(fleet)
    client = logged_in(app)
    assert (
        logged_in(app, "viewer").post("/api/vehicles/agv-02/out-of-service", json={}).status_code
        == 403
    )
    r = client.post("/api/vehicles/agv-02/out-of-service", json={"reason": "bumper check"})
    assert r.status_code == 200, r.text
    assert r.json()["in_service_asked"] is False
    assert _events(client)[-1]["text"] == (
        "agv-02 out of service, asked by operator at testclient: bumper check"
    )
    fleet.advance(1.0)
    shown = client.get("/api/vehicles/agv-02").json()
    assert (shown["in_service"], shown["status"]) == (False, "out-of-service")
    for _ in range(3):  # every task goes to the others
        assert client.post("/api/tasks", json={"station": "pick-A1-1"}).status_code == 201
    fleet.advance(60.0)
    holders = {v.task_id: v.id for v in fleet.vehicles() if v.task_id is not None}
    assert holders
    assert "agv-02" not in holders.values()
    r = client.post("/api/vehicles/agv-02/in-service", json={})
    assert r.json()["in_service_asked"] is True
    fleet.advance(1.0)
    assert client.get("/api/vehicles/agv-02").json()["in_service"] is True
    assert _events(client)[-1]["text"].startswith("agv-02 back in service, asked by operator")
    assert client.post("/api/vehicles/agv-99/out-of-service", json={}).status_code == 404


def _bound_for_pick(fleet: Fleet, client: TestClient) -> tuple[str, str]:
    """Create a task and advance until its vehicle drives to the pick station: the
    vehicle's id and the task's."""
    r = client.post("/api/tasks", json={"station": "pick-A1-1"})
    assert r.status_code == 201
    for _ in range(3000):
        fleet.advance(fleet.config.dt)
        agv = next((a for a in fleet.agvs.values() if a.phase == "to_pick"), None)
        if agv is not None and agv.task is not None and agv.vehicle.speed > 0:
            return agv.node_id, agv.task.id
    pytest.fail("no vehicle drove to the pick station")


def test_a_vehicle_sent_home_over_rest_hands_back_its_task_and_is_logged() -> None:
    fleet = _fleet()
    app = create_app(fleet)
    client = logged_in(app)
    agv_id, task_id = _bound_for_pick(fleet, client)
    assert (
        logged_in(app, "viewer").post(f"/api/vehicles/{agv_id}/send-home", json={}).status_code
        == 403
    )
    r = client.post(f"/api/vehicles/{agv_id}/send-home", json={"reason": "end of shift"})
    assert r.status_code == 200, r.text
    assert r.json()["in_service"] is True, "sent home, it stays in service"
    assert _events(client)[-1]["text"] == (
        f"{agv_id} sent home, asked by operator at testclient: end of shift"
    )
    assert fleet.agvs[agv_id].task is None
    fleet.advance(240.0)
    task = client.get(f"/api/tasks/{task_id}").json()
    assert task["state"] == "done"
    assert task["vehicle"] != agv_id, "another vehicle did it"
    assert fleet.agvs[agv_id].point == fleet.agvs[agv_id].home
    r = client.post("/api/vehicles/agv-99/send-home", json={})
    assert r.status_code == 404
    assert "known: agv-01" in r.json()["detail"]


def test_send_home_is_409_for_a_loaded_or_out_of_service_vehicle() -> None:
    fleet = _fleet()
    client = logged_in(create_app(fleet))
    agv_id, _ = _bound_for_pick(fleet, client)
    agv = fleet.agvs[agv_id]
    for _ in range(6000):
        fleet.advance(fleet.config.dt)
        if agv.phase == "to_drop":
            break
    else:
        pytest.fail(f"{agv_id} never loaded")
    r = client.post(f"/api/vehicles/{agv_id}/send-home", json={})
    assert r.status_code == 409
    assert "is loaded" in r.json()["detail"]
    other = next(a for a in sorted(fleet.agvs) if a != agv_id)
    client.post(f"/api/vehicles/{other}/out-of-service", json={})
    r = client.post(f"/api/vehicles/{other}/send-home", json={})
    assert r.status_code == 409
    assert "out of service" in r.json()["detail"]
    assert not _events(client)[-1]["text"].startswith(f"{other} sent home"), "refused: not logged"


def test_a_fleet_stop_over_rest_pauses_automatic_tasks_until_resumed() -> None:
    fleet = Fleet(config=FleetConfig(agvs=4, seed=3, task_interval=5.0))
    client = logged_in(create_app(fleet))
    fleet.advance(30.0)
    created = fleet.summary()["tasks_created"]
    assert created > 0
    r = client.post("/api/fleet/stop", json={"reason": "inspection"})
    assert r.json()["automatic_tasks"] is False
    fleet.advance(120.0)
    assert fleet.summary()["tasks_created"] == created, "no automatic task while stopped"
    r = client.post("/api/fleet/resume", json={})
    assert r.json()["automatic_tasks"] is True
    fleet.advance(60.0)
    assert fleet.summary()["tasks_created"] > created
