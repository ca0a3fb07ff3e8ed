"""The charging rule both fleets share (``ChargeQueue``) and the control's side of it in
a fleet of AGV processes (``MeshCharging``): who is due, who gets which charger, first
come first served, no two at one; charged, a rest point again; empty, an alarm.
Deterministic: no processes, no clock."""

from __future__ import annotations

from typing import Any

from agv_app.fleet.charge_rule import ChargeQueue, charger_points
from agv_app.fleet.mesh_charging import CHARGE_PROPERTY, MeshCharging, order_in
from agv_app.fleet.parking import ParkingPlan
from agv_app.layout.demo import demo_warehouse
from agv_app.vehicle.battery import BatterySpec
from agv_app.vehicle.kinematics import VehicleSpec

SPEC = BatterySpec(charge_below=30.0, charge_to=80.0)


def _plan(agvs: int) -> tuple[ParkingPlan, dict[str, str]]:
    plan = ParkingPlan(demo_warehouse(), VehicleSpec(), agvs, rest_elsewhere=False)
    homes = {f"agv-{k + 1}": home for k, home in enumerate(plan.homes)}
    for agv_id, home in homes.items():
        plan.claim(agv_id, home)
    return plan, homes


def test_chargers_go_first_come_first_served_and_never_two_to_one() -> None:
    plan, homes = _plan(12)
    rule = ChargeQueue(SPEC, plan, homes)
    chargers = charger_points(plan.layout)
    due = list(homes)  # more AGVs due than chargers
    for k, agv_id in enumerate(due):
        rule.note(agv_id, 20.0, now=float(k))
    assert rule.queue == due
    assert not any(rule.takes_tasks(a) for a in due)
    standing = dict(homes)
    granted = rule.grant(homes, standing, now=20.0)
    points = [p for _, p in granted]
    assert len(set(points)) == len(points), "no two AGVs at one charger"
    assert set(points) <= set(chargers)
    assert [a for a, _ in granted] == due[: len(granted)], "first come, first served"
    assert rule.queue == due[len(granted) :]
    for agv_id, point in granted:
        assert plan.owner(point) == agv_id
        assert rule.status(agv_id) == "to-charger"
    # A charger given up while its AGV still stands on it is not handed out yet.
    first, charger = granted[0]
    homes.update(granted)
    rule.arrived(first)
    assert rule.status(first) == "charging"
    rest = rule.charged(first, charger, charger)
    assert rest is not None
    assert rest not in chargers
    assert rule.takes_tasks(first)
    homes[first] = rest
    standing[first] = charger
    assert rule.grant(homes, standing, now=30.0) == []
    standing[first] = rest
    assert rule.grant(homes, standing, now=31.0) == [(due[len(granted)], charger)]


def test_an_empty_agv_leaves_the_queue_and_raises_one_alarm() -> None:
    plan, homes = _plan(3)
    rule = ChargeQueue(SPEC, plan, homes)
    rule.note("agv-1", 20.0, now=1.0)
    assert rule.note("agv-1", 0.0, now=2.0)
    assert not rule.note("agv-1", 0.0, now=3.0)
    assert rule.queue == []
    assert rule.empty("agv-1")
    assert rule.status("agv-1") == "empty"
    assert [a for _, a, _ in rule.alarms] == ["agv-1"]


def test_the_control_orders_due_then_a_charger_then_a_rest_point() -> None:
    plan, homes = _plan(2)
    published: list[Any] = []
    charging = MeshCharging(SPEC, plan, homes, lambda n, v: published.append((n, v)))
    at = {a: plan.layout.point(h) for a, h in homes.items()}

    def view(level: float, state: str = "idle") -> list[tuple[str, dict[str, Any]]]:
        return [
            (a, {"position": (p.x, p.y), "battery": level, "state": state})
            for a, p in sorted(at.items())
        ]

    charging.tick(view(50.0), now=0.0)
    assert published == []
    charging.tick(view(20.0), now=1.0)  # both due at once
    name, wire = published[-1]
    assert name == CHARGE_PROPERTY
    orders = {a: order_in(wire, a) for a in homes}
    assert all(o is not None and o[1] == "charge" for o in orders.values())
    points = {o[2] for o in orders.values() if o is not None}
    assert len(points) == 2, "two AGVs due at once get two chargers"
    assert order_in(wire, "agv-9") is None
    agv_id = "agv-1"
    number, _, charger = charging.orders[agv_id]
    charging.answer(agv_id, number + 100)  # not its order: nothing happens
    assert charging.orders[agv_id][1] == "charge"
    charging.answer(agv_id, number)
    _, kind, rest = charging.orders[agv_id]
    assert kind == "rest"
    assert rest != charger
    assert plan.owner(charger) is None
    assert plan.owner(rest) == agv_id
    charging.tick(view(20.0), now=2.0)  # a report from before it charged
    assert charging.orders[agv_id][1] == "rest"
    charging.tick(view(0.0, "empty"), now=3.0)
    assert sorted(a for _, a, _ in charging.alarms) == ["agv-1", "agv-2"]


def test_a_malformed_order_is_none() -> None:
    for wrong in (None, "x", [["agv-1", 1, "fly", "P"]], [["agv-1", True, "due", "P"]]):
        assert order_in(wrong, "agv-1") is None
    assert order_in([["agv-1", 3, "due", "P"]], "agv-1") == (3, "due", "P")
