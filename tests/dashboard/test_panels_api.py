"""``GET /api/vehicles/{id}/detail`` and ``/api/membership`` over the real AGV fleet."""

from __future__ import annotations

import math
from typing import Any

import pytest

from agv_app.fleet import Fleet, FleetConfig
from dashboard.app import create_app
from dashboard.state import DashboardState
from dashboard.vehicle_detail import route_length
from tests.dashboard.bodies import poll_body
from tests.dashboard.conftest import NetworkSource, TestClient, advance
from tests.dashboard.login import logged_in


@pytest.fixture
def fleet() -> Fleet:
    return Fleet(config=FleetConfig(agvs=4, seed=3, task_until=0.0))


@pytest.fixture
def client(fleet: Fleet) -> TestClient:
    return logged_in(create_app(fleet))


def dashboard(client: TestClient) -> DashboardState:
    state = client.app.state.dashboard  # type: ignore[attr-defined]
    assert isinstance(state, DashboardState)
    return state


def run_until_driving(fleet: Fleet, client: TestClient, task_id: str) -> dict[str, Any]:
    """Advance the fleet (publishing as the driver does) until the task's AGV drives."""
    state = dashboard(client)
    for _ in range(400):
        fleet.advance(0.1)
        state.publish()
        for v in fleet.vehicles():
            if v.task_id == task_id and v.status == "driving":
                detail = client.get(f"/api/vehicles/{v.id}/detail").json()
                if detail["route"]:
                    return dict(detail)
    raise AssertionError(f"no AGV drove for task {task_id}")


def test_a_resting_vehicle_has_no_route_and_no_wait(client: TestClient) -> None:
    detail = client.get("/api/vehicles/agv-01/detail").json()
    plain = client.get("/api/vehicles/agv-01").json()
    assert {k: detail[k] for k in plain} == plain
    assert detail["route"] == []
    assert detail["destination"] is None
    assert detail["route_length"] == 0.0
    assert detail["wait"] == {"waiting": False, "since": None, "seconds": None}
    traffic = detail["traffic"]
    assert traffic["frames_sent"] == sum(n for n, _ in traffic["sent"].values())
    assert traffic["bytes_sent"] == sum(b for _, b in traffic["sent"].values())


def test_a_driving_vehicle_shows_its_route_locks_sessions_and_traffic(
    fleet: Fleet, client: TestClient
) -> None:
    task_id = client.post("/api/tasks", json={"station": "pick-A1-1"}).json()["task_id"]
    detail = run_until_driving(fleet, client, task_id)
    route = detail["route"]
    assert isinstance(route, list)
    assert len(route) >= 2
    # The route starts where the AGV stands and runs to its destination.
    assert math.dist(route[0], (detail["x"], detail["y"])) < 0.05
    assert detail["destination"] == route[-1]
    assert detail["route_length"] == pytest.approx(route_length(route), abs=0.01)
    assert detail["locked"], "a driving AGV holds floor ahead"
    traffic = detail["traffic"]
    assert isinstance(traffic, dict)
    assert traffic["frames_sent"] > 0
    assert traffic["bytes_sent"] > 0
    # It asked the others for floor (a session it initiates) and voted in theirs or not:
    # both lists agree with the node's own view.
    node = fleet.nodes()[str(detail["id"])]
    assert {s["id"] for s in detail["initiated"]} == {str(i.session_id) for i in node.sessions()}
    assert {p["session_id"] for p in detail["participating"]} == {
        str(p.session_id) for p in node.participations()
    }


def test_a_failed_vehicle_has_no_node_traffic(fleet: Fleet, client: TestClient) -> None:
    fleet.crash("agv-02")
    detail = client.get("/api/vehicles/agv-02/detail").json()
    assert detail["status"] == "failed"
    assert detail["traffic"] is None
    assert detail["initiated"] == []
    assert detail["route"] == []


def test_membership_history_follows_the_fleets_sessions(fleet: Fleet, client: TestClient) -> None:
    task_id = client.post("/api/tasks", json={"station": "pick-A1-1"}).json()["task_id"]
    run_until_driving(fleet, client, task_id)
    listed = client.get("/api/membership").json()
    assert listed, "the fleet's sessions are followed"
    with_members = [s for s in listed if s["joins"] > 0]
    assert with_members
    one = client.get("/api/membership/" + with_members[0]["id"].replace("#", "%23")).json()
    assert one["changes"][0]["change"] == "joined"
    assert one["dropped"] == 0
    assert one["joins"] == sum(c["change"] == "joined" for c in one["changes"])
    assert one["leaves"] == sum(c["change"] == "left" for c in one["changes"])
    live = {s.session_id for s in dashboard(client).sessions().values()}
    for s in listed:
        assert (s["ended_at"] is None) == (s["id"] in live)
    assert len(client.get("/api/membership?limit=1").json()) == 1


@pytest.mark.parametrize(
    ("url", "status"),
    [
        ("/api/vehicles/agv-99/detail", 404),
        ("/api/vehicles/" + "x" * 129 + "/detail", 422),
        ("/api/vehicles/%00/detail", 404),
        ("/api/membership/nobody%231", 404),
        ("/api/membership/" + "x" * 257, 422),
        ("/api/membership?limit=0", 422),
        ("/api/membership?limit=501", 422),
        ("/api/membership?limit=abc", 422),
        ("/api/membership?limit=1e400", 422),
    ],
)
def test_bad_panel_requests_are_4xx(client: TestClient, url: str, status: int) -> None:
    r = client.get(url)
    assert r.status_code == status, r.text
    assert r.json()["detail"]


def test_an_api_sessions_members_join_and_leave_as_they_move(source: NetworkSource) -> None:
    client = logged_in(create_app(source))
    state = dashboard(client)
    # agv-1 at (10, 9) polls within 5 m: agv-2 at (14, 9) is in, then moves away.
    r = client.post("/api/sessions", json=poll_body("agv-1", {"type": "within", "distance": 5.0}))
    sid = r.json()["id"]
    path = "/api/membership/" + sid.replace("#", "%23")
    for _ in range(10):
        advance(source, 0.2)
        state.publish()
    one = client.get(path).json()
    assert one["members"] == ["agv-2"]
    assert [(c["node"], c["change"]) for c in one["changes"]] == [("agv-2", "joined")]
    assert one["definition"]["type"] == "within"
    source.nodes()["agv-2"].update_node_property("position", (40.0, 9.0))
    for _ in range(10):
        advance(source, 0.2)
        state.publish()
    one = client.get(path).json()
    assert one["members"] == []
    assert [(c["node"], c["change"]) for c in one["changes"]] == [
        ("agv-2", "joined"),
        ("agv-2", "left"),
    ]
    assert one["changes"][0]["time"] < one["changes"][1]["time"]
    assert client.delete("/api/sessions/" + sid.replace("#", "%23")).status_code == 200
    state.publish()
    ended = client.get(path).json()
    assert ended["ended_at"] is not None
    assert client.get("/api/membership").json()[0]["id"] == sid


def test_a_fleet_without_vehicles_has_no_vehicle_detail(source: NetworkSource) -> None:
    client = logged_in(create_app(source))
    r = client.get("/api/vehicles/agv-1/detail")  # a node, but no vehicle
    assert r.status_code == 404
    assert "agv-1" in r.json()["detail"]
