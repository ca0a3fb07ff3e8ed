"""Closing part of the floor of a fleet of AGV processes: the observer publishes it, the
vehicle parked inside leaves and waits, and goes home when it reopens.

Real processes on 127.0.0.1; every wait is for an event, with a generous bound.
"""

from __future__ import annotations

import math

import pytest

from agv_app.fleet import MeshFleet
from agv_app.fleet.view import VehicleState
from tests.agv_app.fleet.ready import heard_by_all
from tests.waiting import until

pytestmark = pytest.mark.processes


def _agv(fleet: MeshFleet, agv_id: str) -> VehicleState:
    return next(v for v in fleet.vehicles() if v.id == agv_id)


@pytest.mark.timeout(120)
async def test_an_agv_process_leaves_a_closed_area_and_comes_back_when_it_reopens() -> None:
    fleet = MeshFleet(agvs=2, seed=4, task_interval=None, run_seconds=100.0)
    await fleet.start()
    try:
        await heard_by_all(fleet)
        home = fleet.layout.point(fleet.homes[0])
        square = [
            (home.x - 0.5, home.y - 0.5),
            (home.x + 0.5, home.y - 0.5),
            (home.x, home.y + 0.5),
        ]
        block = fleet.blocks.close("polygon", square, force=True)

        def away_and_waiting() -> bool:
            # Its pose streams faster than its status: wait for both to say so.
            v = _agv(fleet, "agv-01")
            out = math.dist((v.x, v.y), home.xy) > 1.0 and v.speed_m_s == 0.0
            return out and v.status == "waiting"

        await until(away_and_waiting, within=40)
        fleet.blocks.reopen(block.id)

        def back() -> bool:
            v = _agv(fleet, "agv-01")
            return math.dist((v.x, v.y), home.xy) < 0.01 and v.speed_m_s == 0.0

        await until(back, within=40)
        fleet.check()
        assert fleet.monitor.collisions == 0
    finally:
        await fleet.stop()
