"""Closed parts of a floor: what a closure shuts, routes over the open ways, the way
out of a closed point, and the stations a closure would cut off."""

from __future__ import annotations

import math

import pytest

from agv_app.layout import Layout, Point, Segment, Station
from agv_app.layout.blocked import (
    Closed,
    OpenWays,
    UnknownElement,
    closed_by,
    cut_off_stations,
)
from agv_app.layout.elements import LayoutError, NoRouteError


def _ring() -> Layout:
    """A two-way ring A-B-C-D with a spur B-E; stations at A, C and E."""
    points = [
        Point("A", 0, 0),
        Point("B", 10, 0),
        Point("C", 10, 10),
        Point("D", 0, 10),
        Point("E", 13, 0),
    ]
    segments = [
        Segment("AB", "A", "B", bidirectional=True),
        Segment("BC", "B", "C", bidirectional=True),
        Segment("CD", "C", "D", bidirectional=True),
        Segment("DA", "D", "A", bidirectional=True),
        Segment("BE", "B", "E", bidirectional=True),
    ]
    stations = [Station("sa", "A", "pick"), Station("sc", "C", "drop"), Station("se", "E")]
    return Layout(points, segments, stations)


def test_a_closed_segment_is_driven_round() -> None:
    layout = _ring()
    ways = OpenWays(layout, closed_by(layout, "segment", "AB"))
    assert ways.route("A", "B").points == ("A", "D", "C", "B")
    assert ways.distance("A", "B") == 30.0
    assert layout.distance("A", "B") == 10.0, "the layout itself is left as it was"


def test_a_closed_point_closes_the_paths_that_end_at_it() -> None:
    layout = _ring()
    closed = closed_by(layout, "point", "D")
    assert closed == Closed(frozenset({"D"}), frozenset({"CD", "DA"}))
    ways = OpenWays(layout, closed)
    assert ways.route("A", "C").points == ("A", "B", "C")
    with pytest.raises(NoRouteError, match="closed"):
        ways.route("A", "D")
    assert math.isinf(ways.distance("A", "D"))


def test_a_polygon_closes_every_point_and_path_it_touches() -> None:
    layout = _ring()
    closed = closed_by(layout, "polygon", [(8, -1), (12, -1), (12, 1), (8, 1)])
    assert closed.points == {"B"}
    assert closed.segments == {"AB", "BC", "BE"}
    crossing = closed_by(layout, "polygon", [(4, -1), (6, -1), (6, 1), (4, 1)])
    assert crossing == Closed(frozenset(), frozenset({"AB"})), "a path it crosses, no point"


def test_a_vehicle_on_a_closed_point_leaves_by_the_shortest_way_out() -> None:
    layout = _ring()
    ways = OpenWays(layout, closed_by(layout, "point", "B"))
    out = ways.way_out("B")
    assert out is not None
    assert out.points == ("B", "E"), "3 m to E, not 10 m to A or C"
    assert ways.route("B", "C").points == ("B", "C"), "out by the way that leads on"
    assert ways.distance("B", "D") == 20.0
    boxed = OpenWays(layout, Closed(frozenset(layout.points), frozenset(layout.segments)))
    assert boxed.way_out("B") is None, "no way out: it stays"


def test_unknown_ids_and_bad_polygons_are_refused_naming_the_known_ones() -> None:
    layout = _ring()
    with pytest.raises(UnknownElement, match=r"unknown segment 'XY' \(known: AB, BC, BE, CD, DA\)"):
        closed_by(layout, "segment", "XY")
    with pytest.raises(UnknownElement, match="known: A, B, C, D, E"):
        closed_by(layout, "point", "Z")
    with pytest.raises(LayoutError, match="touches no point"):
        closed_by(layout, "polygon", [(50, 50), (51, 50), (51, 51)])
    with pytest.raises(LayoutError, match="crosses itself"):
        closed_by(layout, "polygon", [(0, 0), (2, 2), (2, 0), (0, 2)])


def test_the_stations_a_closure_cuts_off_are_named() -> None:
    layout = _ring()
    assert cut_off_stations(OpenWays(layout, closed_by(layout, "segment", "AB"))) == ()
    assert cut_off_stations(OpenWays(layout, closed_by(layout, "segment", "BE"))) == ("se",)
    assert cut_off_stations(OpenWays(layout, closed_by(layout, "point", "C"))) == ("sc",)
