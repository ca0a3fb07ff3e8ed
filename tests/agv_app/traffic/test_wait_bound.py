"""The wait bound read off a layout and a fleet (``agv_app.traffic.wait_bound``)."""

from __future__ import annotations

import pytest

from agv_app.fleet import Fleet, FleetConfig
from agv_app.layout.demo import demo_warehouse
from agv_app.layout.shapes import crossing, halls, lane_between_areas, lay_by
from agv_app.traffic.deadlock import clearance_for
from agv_app.traffic.reach import longest_no_rest_zone
from agv_app.traffic.wait_bound import WaitBound, longest_request_m, wait_bound
from agv_app.vehicle import VehicleSpec
from agv_app.vehicle.controller import AgvConfig

SPEC = VehicleSpec(2.0, 1.0)


def test_the_bound_is_one_visit_per_other_agv_and_the_latency() -> None:
    bound = WaitBound(agvs=4, longest_request_m=30.0, pass_s=25.0, dwell_s=5.0, latency_s=4.0)
    assert bound.visit_s == 55.0
    assert bound.seconds == 3 * 55.0 + 4.0
    assert bound.for_agvs(1).seconds == 4.0
    assert bound.fleet_within(120.0) == 3  # 2 * 55 + 4 = 114
    assert bound.fleet_within(3.0) == 0
    assert str(bound).startswith("169.0 s = (4 - 1) x 55.0 s")


def test_a_pass_drives_the_longest_request_from_standstill_and_hands_the_floor_on() -> None:
    config = AgvConfig()
    bound = wait_bound(lane_between_areas(40.0), SPEC, config, agvs=3, delay_s=0.01, step_s=0.1)
    # The longest request: a parking spot, the lane and a station spur (4 + 40 + 4 m).
    assert bound.longest_request_m == pytest.approx(48.0)
    handover = 1.0 + 0.5 + 0.04 + 0.1
    assert bound.pass_s == pytest.approx(SPEC.travel_time(48.0) + handover)
    assert bound.latency_s == pytest.approx(2.0 + 0.2 + handover)
    assert bound.seconds == pytest.approx(2 * (2 * bound.pass_s + 5.0) + bound.latency_s)


def test_the_longest_request_follows_the_shape() -> None:
    config = AgvConfig()
    # A crossing: from a parking spot on one arm to the station of the opposite arm,
    # one piece (no resting place on the way), 3 + 4 + 15 + 15 + 3 m plus the spur.
    assert longest_request_m(crossing(), SPEC, config) == pytest.approx(44.0)
    # A lay-by halves the lane: the AGV may wait on it.
    assert longest_request_m(lay_by(60.0), SPEC, config) < longest_request_m(
        lane_between_areas(60.0), SPEC, config
    )
    # Halls: the door and the keep-clear pieces about it, far shorter than the halls.
    assert longest_request_m(halls(), SPEC, config) < 30.0


def test_a_floor_with_many_route_ends_takes_the_closed_form() -> None:
    layout = demo_warehouse()
    config = AgvConfig()
    closed = 1.25 * config.advance_m + longest_no_rest_zone(layout, clearance_for(2.0, 1.0))
    assert longest_request_m(layout, SPEC, config) == pytest.approx(closed)


def test_the_fleet_reports_its_bound_beside_its_longest_wait() -> None:
    fleet = Fleet(crossing(), FleetConfig(agvs=2, seed=1, task_interval=60.0))
    fleet.run(30.0)
    figures = fleet.summary()
    keys = list(figures)
    assert keys[keys.index("max_wait") + 1] == "wait_bound"
    assert figures["wait_bound"] == round(fleet.wait_bound.seconds, 2)
    assert fleet.wait_bound.agvs == 2
