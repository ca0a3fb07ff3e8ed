"""An operator's stop in the simulated fleet: every vehicle brakes to a standstill within
its braking time, stands with its locks, and drives on when resumed. Virtual time."""

from __future__ import annotations

import math

import pytest

from agv_app.fleet import Fleet, FleetConfig
from agv_app.fleet.holding import (
    HOLD_PROPERTY,
    HoldListener,
    HoldOrders,
    held_in,
    in_service_in,
)
from agv_app.fleet.view import OBSERVER_ID
from agv_app.geometry import Area
from agv_app.layout.demo import demo_warehouse
from objectplaces.sim import SimulatedNetwork


def _fleet(**kw: object) -> Fleet:
    cfg = FleetConfig(agvs=6, seed=3, fail_on_violation=True, task_interval=15.0, **kw)  # type: ignore[arg-type]
    return Fleet(demo_warehouse(), cfg)


def _run_until_fast(fleet: Fleet, within_s: float = 300.0) -> None:
    """Run until at least two vehicles drive at more than half their top speed."""
    top = fleet.spec.max_speed_m_s
    for _ in range(round(within_s / fleet.config.dt)):
        fleet.step()
        if sum(a.vehicle.speed > top / 2 for a in fleet.agvs.values()) >= 2:
            return
    pytest.fail("no two vehicles ever drove fast")


def test_a_fleet_stop_stands_every_vehicle_within_its_braking_time_and_keeps_its_locks() -> None:
    fleet = _fleet(task_until=600.0)
    _run_until_fast(fleet)
    spec, dt = fleet.spec, fleet.config.dt
    braking_s = max(a.vehicle.speed for a in fleet.agvs.values()) / spec.max_accel_m_s2
    stops = {a: agv.vehicle.stopping_s() for a, agv in fleet.agvs.items()}

    fleet.stop_vehicles()
    assert fleet.fleet_stopped
    steps = math.ceil(braking_s / dt) + 1  # the braking time and one control step
    for _ in range(steps):
        fleet.step()
    assert {v.id: v.speed_m_s for v in fleet.vehicles()} == dict.fromkeys(fleet.agvs, 0.0)
    assert all(v.held and v.status == "stopped" for v in fleet.vehicles())
    for agv_id, agv in fleet.agvs.items():
        assert agv.vehicle.s <= stops[agv_id] + 1e-9, f"{agv_id} stood within its braking distance"
        assert agv.vehicle.hard_stops == 0
    poses = {a: agv.vehicle.pose() for a, agv in fleet.agvs.items()}
    for _ in range(round(2 * fleet.config.t_update / dt)):  # what it drove past goes
        fleet.step()
    locks = {a: agv.book.lock_areas() for a, agv in fleet.agvs.items()}

    for _ in range(round(300.0 / dt)):  # five minutes stopped
        fleet.step()
        assert not any(agv.stalled for agv in fleet.agvs.values()), "held is no stall"
        for agv in fleet.agvs.values():
            assert agv.vehicle.speed == 0.0
            held = Area.union_of([area for _, area in agv.book.lock_areas()])
            assert held.geom.buffer(1e-6).covers(agv.vehicle.hull().geom), "stands in its locks"
    for agv_id, agv in fleet.agvs.items():
        assert agv.vehicle.pose() == poses[agv_id]
        assert agv.book.lock_areas() == locks[agv_id], f"{agv_id} kept its locks"
    assert fleet.monitor.collisions == 0
    assert fleet.monitor.lock_overlaps == 0

    fleet.resume_vehicles()
    assert not fleet.fleet_stopped
    fleet.run(900.0)
    assert not any(v.held for v in fleet.vehicles())
    figures = fleet.summary()
    assert figures["deadlocks"] == 0, "a long stop is no deadlock"
    assert figures["collisions"] == 0
    assert figures["lock_overlaps"] == 0
    assert figures["tasks_created"] >= 10
    assert fleet.open_tasks == [], "every order went on and was done"
    assert figures["tasks_completed"] == figures["tasks_created"]


def test_one_vehicle_stops_and_resumes_while_the_others_drive() -> None:
    fleet = _fleet()
    _run_until_fast(fleet)
    agv_id, agv = max(fleet.agvs.items(), key=lambda item: item[1].vehicle.speed)
    fleet.stop_vehicles([agv_id])
    fleet.run(60.0)
    assert agv.vehicle.speed == 0.0
    assert agv.display_status() == "stopped"
    moved = {a: o.vehicle.pose() for a, o in fleet.agvs.items() if a != agv_id}
    fleet.run(60.0)
    assert any(o.vehicle.pose() != moved[a] for a, o in fleet.agvs.items() if a != agv_id)
    assert agv.vehicle.speed == 0.0
    fleet.resume_vehicles([agv_id])
    assert not agv.held
    before = agv.vehicle.pose()
    fleet.run(120.0)
    assert agv.vehicle.pose() != before or agv.task is None, "it drives on with its order"


def test_unknown_vehicles_are_named_and_a_vehicle_does_not_resume_a_stopped_fleet() -> None:
    fleet = _fleet()
    with pytest.raises(KeyError, match=r"unknown vehicle 'agv-99' \(known: agv-01, agv-02"):
        fleet.stop_vehicles(["agv-99"])
    assert not any(agv.held for agv in fleet.agvs.values()), "nothing half-applied"
    fleet.stop_vehicles()
    with pytest.raises(ValueError, match="resume the fleet first"):
        fleet.resume_vehicles(["agv-01"])


def test_a_vehicle_out_of_service_parks_at_home_and_takes_no_more() -> None:
    fleet = _fleet()
    _run_until_fast(fleet)
    agv_id, agv = next((a, o) for a, o in fleet.agvs.items() if o.task is not None)
    task = agv.task
    assert task is not None
    loaded = agv.phase in ("to_drop", "at_drop")
    fleet.set_service([agv_id], in_service=False)
    assert not fleet.service_asked(agv_id)
    for _ in range(round(600.0 / fleet.config.dt)):
        fleet.step()
        if agv.display_status() == "out-of-service" and agv.point == agv.home:
            break
    else:
        pytest.fail(f"{agv_id} never parked out of service")
    record = fleet.desk.book.get(task.id)
    assert record is not None
    if loaded:  # one not loaded it hands back (tests/agv_app/fleet/test_service.py)
        assert (record.state, record.vehicle) == ("done", agv_id), "it delivered its load"
    done_before = fleet.summary()["tasks_completed"]
    parked = agv.vehicle.pose()
    fleet.run(600.0)
    assert agv.task is None
    assert agv.pending_task is None, "it took no task while out of service"
    assert agv.vehicle.pose() == parked
    assert fleet.summary()["tasks_completed"] > done_before, "the others carried on"
    view = next(v for v in fleet.vehicles() if v.id == agv_id)
    assert view.in_service is False
    assert view.status == "out-of-service"
    fleet.set_service([agv_id], in_service=True)
    for _ in range(round(900.0 / fleet.config.dt)):
        fleet.step()
        if agv.task is not None:
            break
    else:
        pytest.fail(f"{agv_id} took no task back in service")


def test_the_wire_form_holds_the_fleet_or_the_vehicles_named() -> None:
    orders = HoldOrders()
    orders.stop(["agv-02"])
    assert held_in(orders.wire(), "agv-02") is True
    assert held_in(orders.wire(), "agv-01") is False
    orders.stop()
    assert held_in(orders.wire(), "agv-01") is True
    orders.resume()
    orders.set_service(["agv-03"], in_service=False)
    assert orders.wire() == [False, ["agv-02"], ["agv-03"]]
    assert in_service_in(orders.wire(), "agv-03") is False
    assert in_service_in(orders.wire(), "agv-02") is True
    assert in_service_in([False, []], "agv-03") is True, "the two-list form: all in service"
    assert in_service_in([False, [], "x"], "agv-03") is None
    assert held_in("stop!", "agv-01") is None
    assert held_in([1, []], "agv-01") is None


class _Agv:
    """A stand-in for an AGV component: counts what it is told."""

    node_id = "agv-01"

    def __init__(self) -> None:
        self.held = False
        self.in_service = True

    def hold(self) -> None:
        self.held = True

    def release(self) -> None:
        self.held = False

    def take_out_of_service(self) -> None:
        self.in_service = False

    def return_to_service(self) -> None:
        self.in_service = True


def test_only_the_control_identity_stops_a_vehicle() -> None:
    net = SimulatedNetwork(1)
    control, rogue, node = (net.add_node(n) for n in (OBSERVER_ID, "agv-66", "agv-01"))
    agv = _Agv()
    listener = HoldListener(node, agv)
    rogue.update_node_property(HOLD_PROPERTY, [True, []])
    net.run_for(2.0)
    assert not agv.held, "a peer's word does not stop a vehicle"
    assert listener.refused == 1
    control.update_node_property(HOLD_PROPERTY, [False, ["agv-01"]])
    net.run_for(2.0)
    assert agv.held
    control.update_node_property(HOLD_PROPERTY, "nonsense")
    net.run_for(2.0)
    assert agv.held, "a malformed stop changes nothing"
    assert listener.refused == 2
    control.update_node_property(HOLD_PROPERTY, [False, [], ["agv-01"]])
    net.run_for(2.0)
    assert not agv.held
    assert not agv.in_service
    control.update_node_property(HOLD_PROPERTY, [False, []])
    net.run_for(2.0)
    assert agv.in_service
    # A vehicle that joins later hears the stop in force at once.
    control.update_node_property(HOLD_PROPERTY, [True, []])
    net.run_for(2.0)
    late = _Agv()
    late.node_id = "agv-02"
    HoldListener(net.add_node("agv-02"), late)
    net.run_for(2.0)
    assert late.held
