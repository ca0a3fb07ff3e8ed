"""The parking helper both fleets use: spots, homes, rest points, headings."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import pytest

from agv_app.fleet import ParkingPlan, home_heading, parking_capacity, parking_spots
from agv_app.layout import Layout, Point, Segment, Station
from agv_app.layout.demo import DEMO_VEHICLE_LENGTH_M, DEMO_VEHICLE_WIDTH_M, demo_warehouse
from agv_app.layout.generated import generated_warehouse
from agv_app.layout.json_format import load_any
from agv_app.vehicle import VehicleSpec

SPEC = VehicleSpec(DEMO_VEHICLE_LENGTH_M, DEMO_VEHICLE_WIDTH_M)
DEMO_01 = Path(__file__).resolve().parents[3] / "agv_app/data/opentcs/Demo-01.xml"


def comb() -> Layout:
    """A two-way main lane along y = 0 with three two-way spurs north; a park at each end.

    m0 <-> m10 <-> m20 <-> m30; m10 -> s10, m20 -> s20, m30 -> s30 (dead ends at y = 5);
    parking stations on s10 and s30, a pick station on m0.
    """
    xs = (0, 10, 20, 30)
    points = [Point(f"m{x}", float(x), 0.0) for x in xs]
    points += [Point(f"s{x}", float(x), 5.0) for x in xs[1:]]
    segments = [
        Segment(f"m{a}-m{b}", f"m{a}", f"m{b}", bidirectional=True)
        for a, b in itertools.pairwise(xs)
    ]
    segments += [Segment(f"up{x}", f"m{x}", f"s{x}", bidirectional=True) for x in xs[1:]]
    stations = [
        Station("park-a", "s10", "parking"),
        Station("park-b", "s30", "charging"),
        Station("pick", "m0", "pick"),
    ]
    return Layout(points, segments, stations, name="comb")


def test_spots_are_parking_then_charging_points_and_set_the_capacity() -> None:
    layout = demo_warehouse()
    spots = parking_spots(layout)
    parking = [s.point for s in layout.stations_of_kind("parking")]
    assert spots[: len(parking)] == parking
    assert len(set(spots)) == len(spots) == parking_capacity(layout)
    assert parking_spots(comb()) == ["s10", "s30"]


def test_homes_are_spread_over_the_spots() -> None:
    layout = demo_warehouse()
    spots = parking_spots(layout)
    plan = ParkingPlan(layout, SPEC, 4, rest_elsewhere=False)
    assert plan.homes == [spots[(k * len(spots)) // 4] for k in range(4)]
    assert len(set(plan.homes)) == 4


def test_too_few_spots_is_refused_unless_agvs_may_rest_elsewhere() -> None:
    with pytest.raises(ValueError, match=r"layout 'comb' has room to park 2 AGVs, not 3"):
        ParkingPlan(comb(), SPEC, 3, rest_elsewhere=False)
    plan = ParkingPlan(comb(), SPEC, 3)
    # The dead end s20 comes before any point on the lane.
    assert sorted(plan.homes) == ["s10", "s20", "s30"]


def test_relocate_hands_out_the_nearest_free_point_and_frees_the_old_one() -> None:
    layout = comb()
    plan = ParkingPlan(layout, SPEC, 2, homes=["s10", "s30"])
    plan.claim("agv-1", "s10")
    plan.claim("agv-2", "s30")
    assert plan.relocate("agv-2", "s30", at="m30") is None  # every point is taken
    plan = ParkingPlan(layout, SPEC, 1, homes=["s10", "s30"])
    plan.claim("agv-1", "s10")
    assert plan.relocate("agv-1", "s10", at="m20") == "s30"
    assert plan.relocate("agv-2", "s99", at="m0") == "s10"  # agv-1 gave it up


def test_a_parked_vehicle_faces_along_the_way_into_its_spot() -> None:
    layout = comb()
    assert home_heading(layout, "s10") == pytest.approx(math.pi / 2)
    lone = Layout([Point("a", 0, 0), Point("b", 1, 1)], [Segment("ab", "a", "b")])
    assert home_heading(lone, "b") == pytest.approx(math.pi / 4)
    assert home_heading(lone, "a") == 0.0  # nothing leads into it


def test_spare_points_are_free_spots_first_then_points_clear_of_junctions() -> None:
    # The generated warehouse for 100 AGVs has 123 spots: the 23 no AGV calls home are
    # handed out first. Points elsewhere keep a hull diagonal from every junction: an
    # AGV resting on the one where lane M joins the west column (b1-M@W) locked with
    # one coming down the column (seed 2, 100 AGVs, 3 m requests, after 18 minutes).
    layout = generated_warehouse(100)
    plan = ParkingPlan(layout, SPEC, 100)
    spots = parking_spots(layout)
    spare = plan._pool[len(plan.homes) :]
    assert spare[: len(spots) - 100] == [p for p in spots if p not in plan.homes]
    assert "b1-M@W" not in plan._pool
    gap = math.hypot(SPEC.length_m, SPEC.width_m) + 0.5
    junctions = [layout.point(p) for p in layout.points if len(layout.neighbours(p)) > 2]
    for pid in spare[len(spots) - 100 :]:
        p = layout.point(pid)
        assert all(math.hypot(p.x - j.x, p.y - j.y) >= gap for j in junctions), pid
    # Demo-01's spare points off its five spots: none of them a junction.
    demo01 = load_any(DEMO_01)
    rest = ParkingPlan(demo01, SPEC, 5)._pool[5:]
    assert rest
    assert all(len(demo01.neighbours(p)) <= 2 for p in rest)
