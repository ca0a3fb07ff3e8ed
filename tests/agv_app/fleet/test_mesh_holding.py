"""An operator's stop of AGV processes: the observer publishes it over the fleet's own
links, every vehicle process brakes and stands, and reports so; resume drives them on.

Real processes on 127.0.0.1; every wait is for an event, with a generous bound.
"""

from __future__ import annotations

import asyncio
import math

import pytest

from agv_app.fleet import MeshFleet
from agv_app.fleet.view import VehicleState
from tests.agv_app.fleet.ready import heard_by_all
from tests.waiting import until

pytestmark = pytest.mark.processes

PICKS = ["pick-A3-1", "pick-A1-1", "pick-B2-1"]


def _by_id(fleet: MeshFleet) -> dict[str, VehicleState]:
    return {v.id: v for v in fleet.vehicles()}


@pytest.mark.timeout(180)
async def test_a_fleet_stop_stands_every_agv_process_and_resume_drives_them_on() -> None:
    fleet = MeshFleet(agvs=3, seed=2, task_interval=None, run_seconds=150.0)
    await fleet.start()
    try:
        await heard_by_all(fleet)
        stations = sorted(fleet.stations)
        for pick in [p for p in PICKS if p in fleet.stations] or stations[:3]:
            fleet.create_task(pick)
        await until(lambda: any(v.speed_m_s > 0.0 for v in fleet.vehicles()), within=40)
        assert not any(v.held for v in fleet.vehicles())

        fleet.pause()  # the dashboard's Pause: in process mode, a fleet stop
        assert fleet.fleet_stopped
        await until(lambda: all(v.held and v.speed_m_s == 0.0 for v in fleet.vehicles()), within=20)
        assert {v.status for v in fleet.vehicles()} == {"stopped"}
        stood = {v.id: (v.x, v.y) for v in fleet.vehicles()}
        since = fleet.now
        await until(lambda: fleet.now > since + 3.0, within=10)
        for v in fleet.vehicles():
            assert v.speed_m_s == 0.0, f"{v.id} stays standing"
            assert math.dist(stood[v.id], (v.x, v.y)) < 0.01
            assert v.locked, f"{v.id} keeps its locks"
        fleet.check()
        assert fleet.monitor.collisions == 0

        fleet.resume()
        await until(lambda: not any(v.held for v in fleet.vehicles()), within=20)
        await until(lambda: any(v.speed_m_s > 0.0 for v in fleet.vehicles()), within=30)
        moving = next(v for v in fleet.vehicles() if v.speed_m_s > 0.0)
        assert moving.status != "stopped"
    finally:
        await fleet.stop()


@pytest.mark.timeout(120)
@pytest.mark.parametrize("transport", ["websocket", "zenoh"])
async def test_one_agv_process_stops_on_its_own_and_goes_out_of_service(transport: str) -> None:
    fleet = MeshFleet(agvs=2, seed=4, task_interval=None, run_seconds=100.0, transport=transport)
    await fleet.start()
    try:
        async with asyncio.timeout(40):
            await fleet.wait_ready()
        fleet.stop_vehicles(["agv-02"])
        await until(lambda: _by_id(fleet)["agv-02"].held, within=20)
        assert _by_id(fleet)["agv-02"].status == "stopped"
        assert not _by_id(fleet)["agv-01"].held
        with pytest.raises(KeyError, match=r"known: agv-01, agv-02"):
            fleet.stop_vehicles(["agv-07"])
        fleet.resume_vehicles(["agv-02"])
        await until(lambda: not _by_id(fleet)["agv-02"].held, within=20)
        fleet.set_service(["agv-01"], in_service=False)
        await until(lambda: not _by_id(fleet)["agv-01"].in_service, within=20)
        assert _by_id(fleet)["agv-01"].status == "out-of-service"
        assert _by_id(fleet)["agv-02"].in_service
        fleet.set_service(["agv-01"], in_service=True)
        await until(lambda: _by_id(fleet)["agv-01"].in_service, within=20)
    finally:
        await fleet.stop()
