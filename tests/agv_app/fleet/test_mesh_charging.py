"""Charging in a fleet of AGV processes: the control grants chargers from the reported
state of charge, each process follows over the observer's property ``charge``, charges
on its charger and takes tasks again; one that runs empty stops and raises the alarm.
The rule itself, deterministically: tests/agv_app/fleet/test_charge_rule.py.

Real processes on 127.0.0.1, with batteries that drain within seconds; every wait is for
an event, with a generous bound.
"""

from __future__ import annotations

import asyncio
from collections.abc import Mapping
from typing import Any

import pytest

from agv_app.fleet import MeshFleet
from agv_app.vehicle.battery import BatterySpec
from dashboard.eventlog import EventLog
from dashboard.watch import FleetWatch
from tests.agv_app.fleet.ready import heard_by_all
from tests.waiting import until

pytestmark = pytest.mark.processes

# Due seconds after start, charged in seconds, and not due again within the test.
FAST = BatterySpec(
    drain_per_m=0.05,
    drain_per_load_s=0.05,
    drain_idle_per_s=0.2,
    charge_per_s=20.0,
    charge_below=35.0,
    charge_to=90.0,
    initial=35.5,
)


def _view(fleet: MeshFleet, agv_id: str) -> Mapping[str, Any]:
    return fleet.seen.view(agv_id) or {}


@pytest.mark.timeout(180)
async def test_agv_processes_low_on_charge_charge_at_two_chargers_and_work_again() -> None:
    fleet = MeshFleet(agvs=2, seed=4, task_interval=None, run_seconds=170.0, batteries=FAST)
    await fleet.start()
    try:
        await heard_by_all(fleet)
        charging = fleet.charging
        assert charging is not None
        ids = sorted(fleet.vehicle_ids())
        charged: set[str] = set()
        chargers: dict[str, str] = {}

        def both_charged() -> bool:
            granted = {a: p for a, (_, kind, p) in charging.orders.items() if kind == "charge"}
            assert len(set(granted.values())) == len(granted), "two AGVs at one charger"
            chargers.update(granted)
            for agv_id in ids:
                view = _view(fleet, agv_id)
                if view.get("state") == "charging":
                    charged.add(agv_id)
            return charged == set(ids) and all(
                charging.orders.get(a, (0, ""))[1] == "rest" for a in ids
            )

        await until(both_charged, within=120)
        assert set(chargers) == set(ids)
        assert len(set(chargers.values())) == 2

        def working() -> bool:
            return all(_view(fleet, a).get("in_service") is True for a in ids)

        await until(working, within=20)
        assert not charging.alarms
        task = fleet.create_task(sorted(fleet.stations)[0])

        def taken() -> bool:  # delivering it takes a minute: that it sets off is enough
            record = fleet.desk.book.get(task)
            return record is not None and record.state == "driving" and record.vehicle in ids

        await until(taken, within=60)
    finally:
        await fleet.stop()


@pytest.mark.timeout(120)
async def test_an_agv_process_that_runs_empty_stops_and_the_alarm_shows() -> None:
    never_due = BatterySpec(drain_idle_per_s=1.0, charge_below=0.0, initial=4.0)
    fleet = MeshFleet(agvs=1, seed=5, task_interval=None, run_seconds=100.0, batteries=never_due)
    await fleet.start()
    try:
        await heard_by_all(fleet)
        (agv_id,) = fleet.vehicle_ids()
        await until(lambda: _view(fleet, agv_id).get("state") == "empty", within=30)
        assert _view(fleet, agv_id).get("held") is True
        charging = fleet.charging
        assert charging is not None
        await until(lambda: bool(charging.alarms), within=10)
        assert [a for _, a, _ in charging.alarms] == [agv_id]
        log = EventLog()
        statuses = {v.id: v.status for v in fleet.vehicles()}
        FleetWatch(log).observe(fleet.now, nodes=set(), statuses=statuses, paused=False)
        assert [a.key for a in log.alarms] == [f"empty:{agv_id}"]
        fleet.stop_vehicles([agv_id])
        fleet.resume_vehicles([agv_id])  # the operator's word does not move it
        await asyncio.sleep(1.0)
        assert _view(fleet, agv_id).get("state") == "empty"
    finally:
        await fleet.stop()
