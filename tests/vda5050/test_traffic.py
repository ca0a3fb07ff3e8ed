"""Orders do not override traffic control: the fleet's locks still decide who moves."""

from __future__ import annotations

import json
import math
from collections.abc import Callable

from agv_app.fleet.parking import ParkingPlan, home_heading
from agv_app.layout.demo import DEMO_VEHICLE_LENGTH_M, DEMO_VEHICLE_WIDTH_M, demo_warehouse
from agv_app.traffic.monitor import SafetyMonitor
from agv_app.vda5050.endpoint import VdaEndpoint
from agv_app.vda5050.topics import MANUFACTURER, VehicleTopics
from agv_app.vda5050.vehicle import OrderAgv
from agv_app.vehicle.controller import AgvConfig
from agv_app.vehicle.kinematics import VehicleSpec
from objectplaces.sim import SimulatedNetwork
from tests.vda5050.harness import DT, make_order


class TwoVehicles:
    """Two order-driven AGVs on one simulated network, under the safety monitor."""

    def __init__(self) -> None:
        self.layout = demo_warehouse()
        spec = VehicleSpec(DEMO_VEHICLE_LENGTH_M, DEMO_VEHICLE_WIDTH_M)
        homes = ParkingPlan(self.layout, spec, 2, rest_elsewhere=False).homes
        self.net = SimulatedNetwork(1, property_interval=1.0, failure_timeout=3.0)
        self.agvs: dict[str, OrderAgv] = {}
        self.endpoints: dict[str, VdaEndpoint] = {}
        for i, home in enumerate(homes):
            serial = f"agv-0{i + 1}"
            agv = OrderAgv(
                self.net.add_node(serial),
                self.layout,
                spec,
                home,
                heading_rad=home_heading(self.layout, home),
                config=AgvConfig(),
                manufacturer=MANUFACTURER,
            )
            self.agvs[serial] = agv
            self.endpoints[serial] = VdaEndpoint(agv, VehicleTopics(MANUFACTURER, serial))
        self.monitor = SafetyMonitor()
        self.stalled = dict.fromkeys(self.agvs, 0.0)
        self.closest = math.inf
        self.steps = 0

    def order(self, serial: str, points: list[str], order_id: str) -> None:
        order = make_order(self.layout, serial, points, order_id=order_id)
        self.endpoints[serial].handle("order", json.dumps(order).encode())
        assert list(self.endpoints[serial].errors) == []

    def run(self, seconds: float, until: Callable[[], bool] = lambda: False) -> None:
        for _ in range(round(seconds / DT)):
            self.net.run_for(DT)
            self.steps += 1
            for serial, agv in self.agvs.items():
                agv.step(DT)
                if agv.stalled:
                    self.stalled[serial] += DT
            hulls = [(s, a.vehicle.hull()) for s, a in self.agvs.items()]
            locks = [(s, e.area) for s, a in self.agvs.items() for e in a.book.locks()]
            assert self.monitor.check(self.steps, self.net.now, hulls, locks) == []
            a, b = (agv.vehicle.pose() for agv in self.agvs.values())
            self.closest = min(self.closest, math.hypot(a.x - b.x, a.y - b.y))
            if until():
                return

    def done(self, serial: str) -> bool:
        agv = self.agvs[serial]
        return not agv.book_of_orders.active and agv.at_rest


def test_an_order_through_a_standing_vehicle_waits_until_it_has_gone() -> None:
    t = TwoVehicles()
    first, second = t.agvs["agv-01"], t.agvs["agv-02"]
    through = list(t.layout.shortest_path(first.point, "P0350n"))
    other = list(t.layout.shortest_path(second.point, "P5100n"))
    shared = [n for n in other if n in through]
    meet = shared[len(shared) // 2]
    t.run(2.0)
    t.order("agv-02", other[: other.index(meet) + 1], "park-on-the-lane")
    t.run(200, until=lambda: t.done("agv-02"))
    assert second.point == meet
    t.order("agv-01", through, "through")
    t.run(120)
    assert not t.done("agv-01")
    assert t.stalled["agv-01"] > 60.0, "the order does not let it push past"
    reached = first.book_of_orders.last_node_id
    assert through.index(reached) < through.index(meet)
    t.order("agv-02", other[other.index(meet) :], "away")
    t.run(400, until=lambda: t.done("agv-01") and t.done("agv-02"))
    assert first.point == through[-1]
    assert second.point == other[-1]
    assert t.monitor.collisions == 0
    assert t.monitor.lock_overlaps == 0
    assert first.vehicle.hard_stops == 0
    assert t.closest < 5.0, "they did meet"


def test_an_order_into_a_place_another_vehicle_holds_waits_there_and_does_not_drive_on() -> None:
    """A vehicle of the fleet drives on after a minute at the end of its route (the
    traffic rules' last resort); one following an order keeps to the master control's
    path, however long it waits."""
    t = TwoVehicles()
    first, second = t.agvs["agv-01"], t.agvs["agv-02"]
    path = list(t.layout.shortest_path(second.point, first.point))
    end = t.layout.point(path[-1])
    t.run(2.0)
    t.order("agv-02", path, "into-the-other")
    t.run(150)
    assert not t.done("agv-02")
    assert t.stalled["agv-02"] > 90.0, "well past the fleet's drive-on limit (60 s)"
    assert second.vehicle.route.end == (end.x, end.y), "it still drives the order's path"
    assert second.book_of_orders.active
    assert t.monitor.collisions == t.monitor.lock_overlaps == 0
