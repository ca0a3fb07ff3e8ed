"""VDA 5050 ``powerSupply`` reports the vehicle's battery model when its spec declares
one (virtual time)."""

from __future__ import annotations

from agv_app.fleet.parking import ParkingPlan, home_heading
from agv_app.layout.demo import DEMO_VEHICLE_LENGTH_M, DEMO_VEHICLE_WIDTH_M, demo_warehouse
from agv_app.vda5050.endpoint import VdaEndpoint
from agv_app.vda5050.topics import MANUFACTURER, VehicleTopics
from agv_app.vda5050.vehicle import OrderAgv
from agv_app.vehicle.battery import BatterySpec, SimBattery
from agv_app.vehicle.controller import AgvConfig
from agv_app.vehicle.kinematics import VehicleSpec
from objectplaces.sim import SimulatedNetwork


def test_power_supply_reports_the_battery_the_spec_declares() -> None:
    layout = demo_warehouse()
    spec = VehicleSpec(
        DEMO_VEHICLE_LENGTH_M, DEMO_VEHICLE_WIDTH_M, battery=BatterySpec(initial=64.0)
    )
    home = ParkingPlan(layout, spec, 1, rest_elsewhere=False).homes[0]
    net = SimulatedNetwork(1, property_interval=1.0, failure_timeout=3.0)
    agv = OrderAgv(
        net.add_node("agv-01"),
        layout,
        spec,
        home,
        heading_rad=home_heading(layout, home),
        config=AgvConfig(),
        manufacturer=MANUFACTURER,
    )
    endpoint = VdaEndpoint(agv, VehicleTopics(MANUFACTURER, "agv-01"))
    assert isinstance(agv.battery, SimBattery)
    assert endpoint.state_now()["powerSupply"] == {"stateOfCharge": 64.0, "charging": False}
    agv.battery.drain(metres=400.0)  # 0.01 % a metre
    assert endpoint.state_now()["powerSupply"]["stateOfCharge"] == 60.0
