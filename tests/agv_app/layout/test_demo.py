"""The demo warehouse's traffic plan: one-way loops, two-way only on station spurs."""

from __future__ import annotations

import itertools

import pytest

from agv_app.layout.demo import demo_warehouse
from agv_app.layout.graph import Layout
from agv_app.traffic.deadlock import DEFAULT_CLEARANCE_M, StopPlan

DEMO = demo_warehouse()
SPUR_M = 2.5


def aisle_stations(layout: Layout) -> list[str]:
    """Points of the stations on the aisles' spurs (``pick-A1-1`` and the like)."""
    return sorted(st.point for st in layout.stations.values() if "-A" in st.id)


def test_every_lane_is_one_way_and_only_station_spurs_are_two_way() -> None:
    spots = {st.point for st in DEMO.stations.values()}
    two_way = [s for s in DEMO.segments.values() if s.bidirectional]
    assert len(two_way) == len(spots)
    for seg in two_way:
        assert seg.end in spots, seg.id
        assert DEMO.neighbours(seg.end) == (seg.start,), seg.id
        assert DEMO.segment_length(seg.id) == pytest.approx(SPUR_M)
    # The main lane runs westbound only: no way from its west end straight back east.
    assert DEMO.segment_between("M@E", "M5175") is not None
    assert DEMO.segment_between("M0800", "M@W") is not None
    assert not DEMO.is_bidirectional("M0800", "M@W")
    assert "M0800" not in DEMO.successors("M@W")


def test_an_agv_may_wait_anywhere_on_the_lanes() -> None:
    """Between two stations, the only no-rest zones are round the spurs at the ends."""
    points = sorted(st.point for st in DEMO.stations.values())
    for a, b in itertools.islice(itertools.permutations(points[::7], 2), 400):
        route = DEMO.route(a, b)
        plan = StopPlan.for_route(DEMO, route, clearance_m=DEFAULT_CLEARANCE_M)
        assert plan.zones, (a, b)
        reach = SPUR_M + DEFAULT_CLEARANCE_M + 1e-9
        for lo, hi in plan.zones:
            # Each zone is a spur at one end of the route (or both, merged).
            assert hi <= reach or lo >= route.length - reach or (lo < 0 and hi > route.length)


def test_every_aisle_station_reaches_every_other_within_a_loop_or_two() -> None:
    longest = max(DEMO.distance(a, b) for a, b in itertools.permutations(aisle_stations(DEMO), 2))
    # Round one loop of the aisle block (about 2 x 44 m + 2 x 20 m) plus two spurs, never
    # round the whole floor.
    assert longest < 140.0
