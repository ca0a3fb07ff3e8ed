"""Vehicle kinematics: never past the limit, arrives exactly, stops before a limit."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from agv_app.geometry import Polyline, Pose
from agv_app.vehicle import Vehicle, VehicleSpec

SPEC = VehicleSpec(length_m=2.0, width_m=1.0, max_speed_m_s=1.5, max_accel_m_s2=0.5)
ROUTE = Polyline([(0, 0), (20, 0), (20, 10)])


def test_spec_validation_and_helpers() -> None:
    with pytest.raises(ValueError, match="max_speed_m_s must be positive"):
        VehicleSpec(max_speed_m_s=0)
    with pytest.raises(ValueError, match="length_m must be positive"):
        VehicleSpec(length_m=math.nan)
    assert SPEC.braking_distance(1.0) == pytest.approx(1.0)
    assert SPEC.travel_time(0) == 0.0
    assert SPEC.travel_time(1.0) == pytest.approx(2 * math.sqrt(2))  # never reaches top speed
    assert SPEC.travel_time(30) == pytest.approx(3 + 3 + (30 - 4.5) / 1.5)


def test_reaches_destination_exactly_when_limit_is_the_end() -> None:
    v = Vehicle(SPEC, ROUTE)
    t = 0.0
    while not v.arrived:
        v.step(0.1, math.inf)
        t += 0.1
        assert t < 100
    assert v.s == ROUTE.length
    assert v.remaining() == 0.0
    assert v.speed == 0.0
    assert t == pytest.approx(SPEC.travel_time(ROUTE.length), abs=0.1 + 1e-9)
    pose = v.pose()
    assert (pose.x, pose.y, pose.heading_rad) == pytest.approx((20.0, 10.0, math.pi / 2))
    assert v.hard_stops == 0


def test_stops_at_a_limit_and_goes_on_when_it_moves() -> None:
    v = Vehicle(SPEC, ROUTE)
    for _ in range(300):
        v.step(0.1, 7.5)
    assert (v.s, v.speed) == (7.5, 0.0)
    assert not v.arrived
    for _ in range(300):
        v.step(0.1, 30.0)
    assert v.arrived


def test_drives_at_top_speed_between_limits() -> None:
    v = Vehicle(SPEC, Polyline([(0, 0), (100, 0)]))
    for _ in range(100):
        v.step(0.1, 100.0)
    assert v.speed == pytest.approx(SPEC.max_speed_m_s)
    assert v.stopping_s() == pytest.approx(v.s + SPEC.braking_distance(1.5))


def test_pulled_back_limit_forces_a_counted_hard_stop() -> None:
    v = Vehicle(SPEC, Polyline([(0, 0), (100, 0)]), s=10.0, speed_m_s=1.5)
    moved = v.step(0.1, 10.5)  # 0.5 m ahead, but braking needs 2.25 m
    assert v.s <= 10.5
    assert moved >= 0
    v.step(1.0, 10.5)
    assert (v.s, v.speed) == (10.5, 0.0)
    assert v.hard_stops == 1
    # Standing still past a limit is no further hard stop, and never backwards.
    v.step(1.0, 5.0)
    assert (v.s, v.hard_stops) == (10.5, 1)


def test_bad_arguments() -> None:
    with pytest.raises(ValueError, match="outside route"):
        Vehicle(SPEC, ROUTE, s=99)
    with pytest.raises(ValueError, match="speed 9"):
        Vehicle(SPEC, ROUTE, speed_m_s=9)
    v = Vehicle(SPEC, ROUTE)
    with pytest.raises(ValueError, match="dt must be finite"):
        v.step(-1, 10)
    with pytest.raises(ValueError, match="NaN"):
        v.step(0.1, math.nan)
    assert v.step(0.0, 10) == 0.0


def test_new_route_only_at_rest_and_parked_vehicle() -> None:
    v = Vehicle.parked(SPEC, Pose(3, 4, 1.0))
    assert v.arrived
    assert v.pose() == Pose(3.0, 4.0, 1.0)
    assert v.hull().area_m2 == pytest.approx(2.0)
    v.new_route(Polyline([(3, 4), (3, 10)]))
    v.step(1.0, 10.0)
    with pytest.raises(ValueError, match="cannot change route at speed"):
        v.new_route(Polyline([(0, 0)]))
    for _ in range(100):
        v.step(0.5, 10.0)
    v.new_route(Polyline([(3.0, 10.0)]))
    assert v.pose().heading_rad == pytest.approx(math.pi / 2)  # keeps facing north
    with pytest.raises(ValueError, match="outside route"):
        v.new_route(ROUTE, s=-1)


@given(
    st.lists(st.tuples(st.floats(0.001, 2.0), st.floats(0, 40)), min_size=1, max_size=200),
)
def test_never_passes_a_growing_limit(steps: list[tuple[float, float]]) -> None:
    v = Vehicle(SPEC, ROUTE)
    limit = 0.0
    for dt, bump in steps:
        # Locks only grow while the vehicle drives; a growth of 0 is common.
        limit = max(limit, min(bump, limit + bump / 4))
        prev = v.s
        v.step(dt, limit)
        assert prev <= v.s <= min(limit, ROUTE.length)
        assert 0.0 <= v.speed <= SPEC.max_speed_m_s
        # It can always still stop inside its limit.
        assert v.stopping_s() <= min(limit, ROUTE.length) + 1e-9
    assert v.hard_stops == 0


@given(st.lists(st.tuples(st.floats(0.001, 2.0), st.floats(0, 40)), min_size=1, max_size=100))
def test_never_passes_any_limit(steps: list[tuple[float, float]]) -> None:
    v = Vehicle(SPEC, ROUTE)
    for dt, limit in steps:
        before = v.s
        v.step(dt, limit)
        assert v.s >= before
        assert v.s <= max(before, limit)


@given(st.lists(st.floats(0.01, 0.5), min_size=1, max_size=50), st.floats(0.5, 29.0))
def test_arrival_does_not_depend_on_step_sizes(dts: list[float], limit: float) -> None:
    v = Vehicle(SPEC, ROUTE)
    best = SPEC.travel_time(limit)
    elapsed, k = 0.0, 0
    while not (v.speed == 0 and v.s == limit):
        assert elapsed <= best + 1e-9  # not later than the time-optimal profile allows
        dt = dts[k % len(dts)]
        v.step(dt, limit)
        elapsed += dt
        k += 1
    assert elapsed >= best - 1e-9
    assert v.hard_stops == 0
