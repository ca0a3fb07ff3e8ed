"""A wait limit: only the largest fleet whose wait bound is within it takes tasks, the
rest stay parked as a reserve that never moves, and the bound counts the AGVs in
service (``FleetConfig.wait_limit``; docs/traffic.md, "Bounded waits")."""

from __future__ import annotations

from pathlib import Path

import pytest

from agv_app.fleet import Fleet, FleetConfig
from agv_app.layout.demo import DEMO_VEHICLE_LENGTH_M, DEMO_VEHICLE_WIDTH_M
from agv_app.layout.json_format import save_layout
from agv_app.layout.shapes import crossing
from agv_app.vehicle.battery import BatterySpec
from agv_app.vehicle.kinematics import VehicleSpec
from objectplaces.cli import main


def test_eight_agvs_on_one_crossing_put_two_in_service_and_no_wait_passes_their_bound() -> None:
    layout = crossing()
    whole = Fleet(layout, FleetConfig(agvs=8, seed=3))
    assert whole.active == 8
    assert whole.wait_bound.seconds > 500  # every other AGV counted once
    fleet = Fleet(layout, FleetConfig(agvs=8, seed=3, wait_limit=120.0))
    assert fleet.active == whole.wait_bound.fleet_within(120.0) == 2
    assert fleet.wait_bound == whole.wait_bound.for_agvs(2)
    assert fleet.wait_bound.seconds <= 120.0
    ids = sorted(fleet.agvs)
    working, reserve = ids[:2], ids[2:]
    assert [fleet.service_asked(a) for a in working] == [True, True]
    assert not any(fleet.service_asked(a) for a in reserve)
    parked = {v.id: (v.x, v.y, v.heading_rad) for v in fleet.vehicles() if v.id in reserve}
    fleet.run(900.0)
    figures = fleet.summary()
    assert figures["collisions"] == figures["lock_overlaps"] == 0
    assert figures["tasks_completed"] >= 5
    assert figures["max_wait"] <= figures["wait_bound"] <= 120.0
    after = {v.id: (v.x, v.y, v.heading_rad) for v in fleet.vehicles() if v.id in reserve}
    assert after == parked
    busy = {r.vehicle for r in fleet.desk.book.records() if r.vehicle is not None}
    assert busy <= set(working)


def test_a_limit_the_fleet_keeps_anyway_changes_nothing() -> None:
    fleet = Fleet(crossing(), FleetConfig(agvs=2, seed=1, wait_limit=3600.0))
    assert fleet.active == 2
    assert all(fleet.service_asked(a) for a in fleet.agvs)


def test_a_limit_below_one_agvs_own_latency_is_refused_with_the_latency() -> None:
    with pytest.raises(ValueError, match=r"wait_limit 2 s is below one AGV's own latency, 3\.8 s"):
        Fleet(crossing(), FleetConfig(agvs=4, seed=1, wait_limit=2.0))


def test_a_limit_with_batteries_is_refused_rather_than_broken_by_a_charging_trip() -> None:
    with pytest.raises(ValueError, match="wait_limit and batteries"):
        FleetConfig(agvs=4, wait_limit=120.0, batteries=BatterySpec())
    spec = VehicleSpec(DEMO_VEHICLE_LENGTH_M, DEMO_VEHICLE_WIDTH_M, battery=BatterySpec())
    with pytest.raises(ValueError, match="batteries"):
        Fleet(crossing(), FleetConfig(agvs=4, seed=1, wait_limit=120.0), spec=spec)
    with pytest.raises(ValueError, match="wait_limit must be a positive number"):
        FleetConfig(wait_limit=-1.0)


def test_the_command_line_says_how_many_take_tasks_and_prints_their_bound(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "crossing.json"
    save_layout(crossing(), path)
    argv = ["sim", "--layout", str(path), "--agvs", "8", "--minutes", "0.5", "--quiet"]
    assert main([*argv, "--wait-limit", "120"]) == 0
    out, err = capsys.readouterr()
    assert "2 of 8 AGVs take tasks, the rest stay parked as a reserve" in err
    assert "76.8 s = (2 - 1) x" in out
    assert main([*argv, "--wait-limit", "2"]) == 2
    assert "below one AGV's own latency" in capsys.readouterr().err
