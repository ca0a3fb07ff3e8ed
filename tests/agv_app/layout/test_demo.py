"""The demo warehouse's traffic plan: one-way loops, keep-clear boxes, station spurs."""

from __future__ import annotations

import itertools
import math

import pytest

from agv_app.layout.demo import DEMO_VEHICLE_LENGTH_M, DEMO_VEHICLE_WIDTH_M, demo_warehouse
from agv_app.layout.graph import Layout
from agv_app.traffic.deadlock import DEFAULT_CLEARANCE_M, StopPlan

DEMO = demo_warehouse()
SPUR_M = 2.5
DEMO_LENGTH = DEMO_VEHICLE_LENGTH_M
DEMO_HALF_DIAGONAL = math.hypot(DEMO_VEHICLE_LENGTH_M, DEMO_VEHICLE_WIDTH_M) / 2


def aisle_stations(layout: Layout) -> list[str]:
    """Points of the stations on the aisles' spurs (``pick-A1-1`` and the like)."""
    return sorted(st.point for st in layout.stations.values() if "-A" in st.id)


def test_every_lane_is_one_way_two_way_only_on_spurs_and_keep_clear_boxes() -> None:
    spots = {st.point for st in DEMO.stations.values()}
    two_way = [s for s in DEMO.segments.values() if s.bidirectional]
    spurs = [s for s in two_way if s.end in spots]
    boxes = [s for s in two_way if s.start.endswith("-box")]
    assert len(spurs) == len(spots)
    assert len(boxes) == 10  # 8 aisle ends, the M lane into the W column, N into E
    assert len(spurs) + len(boxes) == len(two_way)
    for seg in spurs:
        assert DEMO.neighbours(seg.end) == (seg.start,), seg.id
        assert DEMO.segment_length(seg.id) == pytest.approx(SPUR_M)
    for seg in boxes:
        # Driven into the junction only: from the junction the box leads nowhere.
        assert DEMO.successors(seg.start) == (seg.end,), seg.id
        assert len(DEMO.neighbours(seg.start)) == 2
        assert DEMO.is_passing_place(seg.end), seg.id
    # The main lane runs westbound only.
    assert DEMO.segment_between("M@E", "M5175") is not None
    assert "M0800" not in DEMO.successors("M@W")
    assert "M0800" not in DEMO.successors("M@W-box")


def test_no_route_drives_a_keep_clear_box_backwards() -> None:
    points = sorted(st.point for st in DEMO.stations.values())
    for a, b in itertools.permutations(points[::4], 2):
        path = DEMO.shortest_path(a, b)
        for u, v in itertools.pairwise(path):
            assert not (v.endswith("-box") and DEMO.is_bidirectional(u, v)), (a, b, u, v)


def test_a_merging_agv_waits_clear_of_the_lane_and_crosses_the_junction_in_one_go() -> None:
    """From the last aisle station to the main lane: no rest between the aisle and a
    hull length beyond the junction, so it never stands turning in the junction."""
    route = DEMO.route("A2-1", "M@W")  # aisle 2 runs south into the main lane at M1425
    plan = StopPlan.for_route(DEMO, route, clearance_m=DEFAULT_CLEARANCE_M)
    junction = route.offsets[route.points.index("M1425")]
    box = route.offsets[route.points.index("A2-box")]
    ((lo, hi),) = [z for z in plan.zones if z[0] < junction < z[1]]
    assert lo <= box - DEFAULT_CLEARANCE_M + 1e-9
    assert hi >= junction + DEFAULT_CLEARANCE_M - 1e-9
    # Waiting before the box, its hull stays clear of the main lane and its turns.
    y_wait = DEMO.point("A2-1").y - lo
    assert y_wait - DEMO_LENGTH / 2 > DEMO.point("M1425").y + DEMO_HALF_DIAGONAL


def test_an_agv_may_wait_anywhere_on_the_lanes_but_at_spurs_and_boxes() -> None:
    """Between two stations, the only no-rest zones are round the spurs at the ends and
    round the keep-clear boxes of the merges it passes, each a few metres long."""
    points = sorted(st.point for st in DEMO.stations.values())
    for a, b in itertools.islice(itertools.permutations(points[::7], 2), 400):
        route = DEMO.route(a, b)
        plan = StopPlan.for_route(DEMO, route, clearance_m=DEFAULT_CLEARANCE_M)
        marks = [0.0, route.length]
        marks += [s for p, s in zip(route.points, route.offsets, strict=True) if "-box" in p]
        for lo, hi in plan.zones:
            assert any(lo < s < hi for s in marks), (a, b, lo, hi)
            assert min(hi, route.length) - max(lo, 0.0) < 13.0, (a, b, lo, hi)


def test_every_aisle_station_reaches_every_other_within_a_loop_or_two() -> None:
    longest = max(DEMO.distance(a, b) for a, b in itertools.permutations(aisle_stations(DEMO), 2))
    # Round one loop of the aisle block (about 2 x 44 m + 2 x 20 m) plus two spurs, never
    # round the whole floor.
    assert longest < 140.0
