"""``/api/vehicles``: the AGVs of the real fleet as they stand."""

from __future__ import annotations

import math

import pytest

from agv_app.fleet import Fleet, FleetConfig
from agv_app.vehicle.battery import BatterySpec
from dashboard.app import create_app
from tests.dashboard.conftest import TestClient
from tests.dashboard.login import logged_in

FIELDS = {
    "id", "x", "y", "heading", "length", "width", "status", "task",
    "hull", "hull_length", "locked", "requested", "speed", "held", "in_service", "battery",
}  # fmt: skip


@pytest.fixture
def fleet() -> Fleet:
    return Fleet(config=FleetConfig(agvs=4, seed=3, task_until=0.0))


@pytest.fixture
def fleet_client(fleet: Fleet) -> TestClient:
    return logged_in(create_app(fleet))


def test_every_vehicle_is_listed_by_id(fleet: Fleet, fleet_client: TestClient) -> None:
    vehicles = fleet_client.get("/api/vehicles").json()
    assert [v["id"] for v in vehicles] == sorted(v.id for v in fleet.vehicles())
    for listed in vehicles:
        assert set(listed) == FIELDS
        assert len(listed["hull"]) == 4
        assert all(math.isfinite(c) for c in (listed["x"], listed["y"], listed["heading"]))
        assert fleet_client.get(f"/api/vehicles/{listed['id']}").json() == listed
        assert listed["battery"] is None  # no battery model


def test_the_state_of_charge_is_listed_with_batteries() -> None:
    fleet = Fleet(config=FleetConfig(agvs=2, seed=3, task_until=0.0, batteries=BatterySpec()))
    client = logged_in(create_app(fleet))
    fleet.advance(120.0)
    vehicles = client.get("/api/vehicles").json()
    levels = [v["battery"] for v in vehicles]
    assert all(isinstance(level, float) for level in levels)
    assert all(99.0 < level < 100.0 for level in levels)  # it drains while standing
    chargers = fleet.chargers
    assert chargers is not None
    chargers.batteries["agv-01"].drain(idle_s=1e9)
    fleet.advance(0.2)
    shown = client.get("/api/vehicles/agv-01").json()
    assert shown["battery"] == 0.0
    assert shown["status"] == "empty"


def test_a_vehicle_with_a_task_shows_it(fleet: Fleet, fleet_client: TestClient) -> None:
    task_id = fleet_client.post("/api/tasks", json={"station": "pick-A1-1"}).json()["task_id"]
    for _ in range(300):
        fleet.advance(0.1)
        holders = [v for v in fleet_client.get("/api/vehicles").json() if v["task"] == task_id]
        if holders:
            break
    (holder,) = holders
    assert holder["status"] != "idle"
    assert holder["locked"], "a vehicle with a task locks floor ahead"


@pytest.mark.parametrize(
    ("url", "status"),
    [
        ("/api/vehicles/agv-99", 404),
        ("/api/vehicles/" + "x" * 129, 422),
        ("/api/vehicles/%00", 404),
    ],
)
def test_bad_vehicle_requests_are_4xx(fleet_client: TestClient, url: str, status: int) -> None:
    r = fleet_client.get(url)
    assert r.status_code == status, r.text
    assert r.json()["detail"]


def test_unknown_vehicle_names_the_known_ones(fleet_client: TestClient) -> None:
    detail = fleet_client.get("/api/vehicles/agv-99").json()["detail"]
    assert "'agv-99'" in detail
    assert "agv-01" in detail
