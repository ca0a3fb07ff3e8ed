"""A shortened request out of a dead-end station ends clear of the lane it joins."""

from __future__ import annotations

from agv_app.fleet import Fleet, FleetConfig
from agv_app.layout.demo import demo_warehouse


def test_an_agv_held_up_leaving_a_station_spur_waits_in_the_spur() -> None:
    # agv-02 leaves the station A3-3e (a 2.5 m spur east of aisle A3) for the N lane;
    # agv-01 stands at A3-box, the aisle's keep-clear box before the N lane, so the
    # way out is held up. The spur and the box make one no-rest zone that the route
    # drives through, where a follower may wait once clear of its start by twice the
    # clearance: a halved request ended there, the hull still across the aisle at the
    # spur's mouth, and an AGV coming up the aisle locked with it.
    cfg = FleetConfig(agvs=2, seed=1, task_interval=1e9, start_tasks=0, fail_on_violation=True)
    fleet = Fleet(demo_warehouse(), cfg, homes=["A3-box", "N5300n"], starts=["A3-box", "A3-3e"])
    leaving = fleet.agvs["agv-02"]
    stops = []
    for _ in range(300):
        fleet.step()
        if fleet.agvs["agv-01"].point == "A3-box" and leaving.vehicle.speed == 0.0:
            stops.append(leaving.vehicle.pose().x)
    assert stops, "agv-02 was never held up"
    # The aisle's centre line is x = 20.5 and the spur's end x = 23.0: standing, the
    # 2 m hull along the spur stays east of the aisle's 1 m lane.
    assert min(stops) >= 20.5 + 0.5 + 1.0 - 1e-6
