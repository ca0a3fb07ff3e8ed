"""A vehicle cut off from its fleet stops inside its locked floor and resumes by itself."""

from __future__ import annotations

from agv_app.fleet import Fleet, FleetConfig
from agv_app.layout.demo import demo_warehouse


def test_a_vehicle_that_hears_nobody_stops_inside_its_locks_and_drives_on_when_heard() -> None:
    # Two AGVs: the other's last circle (a stale record once it is lost) does not cover
    # the way of this one, so only being cut off stops it.
    fleet = Fleet(demo_warehouse(), FleetConfig(agvs=2, seed=5, load=0.9, fail_on_violation=True))
    fleet.run(30.0)
    while not any(a.vehicle.speed > 0 and a.task is not None for a in fleet.agvs.values()):
        fleet.run(1.0)
    agv = next(a for a in fleet.agvs.values() if a.vehicle.speed > 0 and a.task is not None)
    others = [n for n in fleet.net.nodes if n != agv.node_id]
    fleet.net.partition([agv.node_id], others)
    fleet.run(20.0)  # past the failure timeout: it hears nobody, nobody hears it
    assert agv.cut_off.cut_off
    assert agv.vehicle.speed == 0.0, "it stopped"
    locked, request = agv.areas()
    assert request is None, "it asks for nothing while cut off"
    assert agv.book.lock_end(default=agv.vehicle.s) >= agv.vehicle.s - 1e-6
    s_cut = agv.vehicle.s
    fleet.run(20.0)
    assert agv.vehicle.s == s_cut, "it stays stopped, its locks kept"
    assert locked, "it keeps its locks"
    phase = agv.phase
    fleet.net.heal()
    fleet.run(120.0)  # safe: fail_on_violation raised on any overlap or collision
    assert not agv.cut_off.cut_off
    assert agv.cut_off.times_cut_off == 1
    assert agv.phase != phase, "it drove on to its station by itself"
