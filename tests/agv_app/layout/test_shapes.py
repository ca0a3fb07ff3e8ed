"""Floors drawn by hand (``agv_app.layout.shapes``): their stations, lanes and resting places."""

from __future__ import annotations

import pytest

from agv_app.fleet import parking_capacity
from agv_app.layout.shapes import crossing, halls, lane_between_areas, lay_by
from agv_app.traffic.deadlock import StopPlan, clearance_for, followable_segments, merge_branches


def _kinds(layout: object) -> dict[str, int]:
    counts: dict[str, int] = {}
    for station in layout.stations.values():  # type: ignore[attr-defined]
        counts[station.kind] = counts.get(station.kind, 0) + 1
    return counts


def test_a_crossing_has_a_station_and_parking_at_every_arm_end() -> None:
    layout = crossing()
    assert _kinds(layout) == {"pickdrop": 4, "parking": 8}
    assert len(layout.usable_stations()) == 12
    assert all(s.bidirectional for s in layout.segments.values())
    assert layout.route("n-st", "s-st").points == ("n-st", "n", "c", "s", "s-st")
    assert _kinds(crossing((10.0, 12.0, 8.0), parking=1)) == {"pickdrop": 3, "parking": 3}
    assert _kinds(crossing(parking=0)) == {"pickdrop": 4}
    with pytest.raises(ValueError, match="2 to 4 arms"):
        crossing((10.0,))
    with pytest.raises(ValueError, match="0, 1 or 2"):
        crossing(parking=3)


def test_a_lane_joins_two_dead_end_areas() -> None:
    layout = lane_between_areas(30.0, stations=(2, 1), parking=(1, 2))
    assert _kinds(layout) == {"pickdrop": 3, "parking": 3}
    assert parking_capacity(layout) == 3
    assert layout.distance("a0", "b0") == pytest.approx(4.0 + 30.0 + 4.0)
    assert followable_segments(layout) == frozenset()  # every route ends in the areas
    with pytest.raises(ValueError, match="1 to 3 spurs"):
        lane_between_areas(stations=(2, 2), parking=(2, 1))


def test_a_lay_by_lets_agvs_wait_halfway_and_pass() -> None:
    layout = lay_by(60.0, bay_m=14.0)
    assert not layout.segment("bay-w>bay-e").bidirectional
    assert not layout.segment("bay-e>bay-w").bidirectional
    clearance = clearance_for(2.0, 1.0)
    for a, b in (("a0", "b0"), ("b0", "a0")):
        route = layout.route(a, b)
        plan = StopPlan.for_route(
            layout, route, clearance_m=clearance, merges=merge_branches(layout), merge_box_m=1.5
        )
        middle = route.length / 2
        assert plan.may_rest(middle), (a, b, plan.zones)
        assert not plan.may_rest(middle / 2)
    with pytest.raises(ValueError, match="shorter than the lane"):
        lay_by(20.0, bay_m=20.0)


def test_two_halls_share_one_door_that_agvs_follow_each_other_through() -> None:
    layout = halls(stations=(2, 3), parking=(3, 2))
    assert _kinds(layout) == {"pickdrop": 5, "parking": 5}
    assert followable_segments(layout) == frozenset({"w-door>e-door"})
    two_way = sorted(s.id for s in layout.segments.values() if s.bidirectional)
    assert [s for s in two_way if "door" in s] == ["w-door>e-door"]
    assert len(layout.usable_stations()) == 10  # each hall is a ring, the door both ways
    with pytest.raises(ValueError, match="station and a parking spot"):
        halls(stations=(0, 1))
