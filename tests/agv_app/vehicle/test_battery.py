"""The battery model: drains per metre and per second of load handling, charges on a
charger, stays within 0..100 %, and VDA 5050 powerSupply reports it."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from agv_app.vda5050.charging import Battery, battery_of, power_supply
from agv_app.vehicle.battery import BatterySpec, SimBattery
from agv_app.vehicle.kinematics import VehicleSpec

amounts = st.floats(min_value=0.0, max_value=1e4, allow_nan=False)
steps = st.lists(st.tuples(amounts, amounts, amounts), max_size=40)


def test_spec_drains_per_metre_and_per_second_of_load() -> None:
    battery = SimBattery(BatterySpec(drain_per_m=0.5, drain_per_load_s=2.0, drain_idle_per_s=1.0))
    assert battery.drain(metres=10.0) == pytest.approx(95.0)
    assert battery.drain(load_s=2.0) == pytest.approx(91.0)
    assert battery.drain(idle_s=1.0) == pytest.approx(90.0)


def test_vehicle_spec_declares_no_battery_by_default() -> None:
    assert VehicleSpec().battery is None
    spec = VehicleSpec(battery=BatterySpec(drain_per_m=0.2))
    assert spec.battery is not None
    assert spec.battery.drain_per_m == 0.2


@pytest.mark.parametrize(
    "kwargs",
    [
        {"drain_per_m": -1.0},
        {"charge_per_s": 0.0},
        {"charge_below": 95.0, "charge_to": 90.0},
        {"initial": 101.0},
        {"drain_per_load_s": float("nan")},
    ],
)
def test_spec_refuses_nonsense(kwargs: dict[str, float]) -> None:
    with pytest.raises(ValueError, match="BatterySpec"):
        BatterySpec(**kwargs)


def test_charges_at_its_rate_and_stops_full() -> None:
    battery = SimBattery(BatterySpec(charge_per_s=1.0), state_of_charge=50.0)
    battery.start_charging(10.0)
    assert battery.charging
    assert battery.state_of_charge(30.0) == pytest.approx(70.0)
    assert battery.drain(metres=1000.0) == 50.0  # the charger powers it
    assert battery.state_of_charge(100.0) == 100.0
    assert not battery.charging


def test_stop_charging_keeps_what_it_gained() -> None:
    battery = SimBattery(BatterySpec(charge_per_s=0.5), state_of_charge=10.0)
    battery.start_charging(0.0)
    battery.stop_charging(20.0)
    assert not battery.charging
    assert battery.state_of_charge(99.0) == pytest.approx(20.0)


def test_empty_at_zero() -> None:
    battery = SimBattery(BatterySpec(drain_per_m=1.0), state_of_charge=5.0)
    assert not battery.empty
    assert battery.drain(metres=50.0) == 0.0
    assert battery.empty


def test_power_supply_reports_the_model() -> None:
    battery = SimBattery(BatterySpec(drain_per_m=1.0))
    battery.drain(metres=12.5)

    class Agv:
        pass

    agv = Agv()
    agv.battery = battery  # type: ignore[attr-defined]
    assert isinstance(battery, Battery)
    assert battery_of(agv) is battery
    assert power_supply(battery_of(agv), 0.0) == {"stateOfCharge": 87.5, "charging": False}


@given(start=st.floats(0.0, 100.0), steps=steps)
def test_never_below_0_and_drains_monotonically(
    start: float, steps: list[tuple[float, float, float]]
) -> None:
    battery = SimBattery(BatterySpec(), state_of_charge=start)
    last = battery.state_of_charge(0.0)
    for metres, load_s, idle_s in steps:
        level = battery.drain(metres=metres, load_s=load_s, idle_s=idle_s)
        assert 0.0 <= level <= last
        last = level


@given(
    start=st.floats(0.0, 100.0),
    rate=st.floats(1e-3, 10.0),
    times=st.lists(st.floats(0.0, 1e5), max_size=20),
)
def test_charging_never_above_100_and_never_falls(
    start: float, rate: float, times: list[float]
) -> None:
    battery = SimBattery(BatterySpec(charge_per_s=rate), state_of_charge=start)
    battery.start_charging(0.0)
    last = start
    for now in sorted(times):
        level = battery.state_of_charge(now)
        assert last - 1e-9 <= level <= 100.0
        last = level
