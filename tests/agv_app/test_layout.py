"""Layout graph: validation errors, routing, passing places, station reachability."""

from __future__ import annotations

import math

import pytest

from agv_app.layout import (
    Layout,
    LayoutError,
    NoRouteError,
    Point,
    Segment,
    Station,
)


def square(**kwargs: object) -> Layout:
    """a -> b <-> c -> d -> a, with a curved d -> a."""
    return Layout(
        [Point("a", 0, 0), Point("b", 10, 0), Point("c", 10, 10), Point("d", 0, 10)],
        [
            Segment("ab", "a", "b"),
            Segment("bc", "b", "c", bidirectional=True),
            Segment("cd", "c", "d"),
            Segment("da", "d", "a", via=((-2.0, 5.0),)),
        ],
        [Station("s1", "a", "pick"), Station("s2", "c", "drop")],
        **kwargs,  # type: ignore[arg-type]
    )


# -- validation -------------------------------------------------------------------


def test_duplicate_point_id() -> None:
    with pytest.raises(LayoutError, match="duplicate point id 'a'"):
        Layout([Point("a", 0, 0), Point("a", 1, 0)], [])


def test_duplicate_segment_id() -> None:
    with pytest.raises(LayoutError, match="duplicate segment id 's'"):
        Layout(
            [Point("a", 0, 0), Point("b", 1, 0)],
            [Segment("s", "a", "b"), Segment("s", "b", "a")],
        )


def test_duplicate_station_id() -> None:
    with pytest.raises(LayoutError, match="duplicate station id 'x'"):
        Layout([Point("a", 0, 0)], [], [Station("x", "a"), Station("x", "a")])


def test_unknown_end_point_names_segment_and_point() -> None:
    with pytest.raises(LayoutError, match="segment 's': unknown end point 'zz'"):
        Layout([Point("a", 0, 0)], [Segment("s", "a", "zz")])


def test_zero_length_segment() -> None:
    with pytest.raises(LayoutError, match="segment 's': zero length"):
        Layout([Point("a", 0, 0), Point("b", 0, 0)], [Segment("s", "a", "b")])


def test_loop_segment() -> None:
    with pytest.raises(LayoutError, match="segment 's': starts and ends at point 'a'"):
        Layout([Point("a", 0, 0)], [Segment("s", "a", "a")])


def test_repeated_via_vertex() -> None:
    with pytest.raises(LayoutError, match="segment 's': zero-length piece 1"):
        Layout(
            [Point("a", 0, 0), Point("b", 4, 0)],
            [Segment("s", "a", "b", via=((2.0, 1.0), (2.0, 1.0)))],
        )


def test_non_finite_point() -> None:
    with pytest.raises(LayoutError, match="point 'a': non-finite"):
        Layout([Point("a", math.nan, 0)], [])


def test_parallel_segments_in_same_direction() -> None:
    with pytest.raises(LayoutError, match="segment 't': 'b' -> 'a' is already served by"):
        Layout(
            [Point("a", 0, 0), Point("b", 1, 0)],
            [Segment("s", "a", "b", bidirectional=True), Segment("t", "b", "a")],
        )


def test_station_unknown_point() -> None:
    with pytest.raises(LayoutError, match="station 'x': unknown point 'q'"):
        Layout([Point("a", 0, 0)], [], [Station("x", "q")])


def test_station_unknown_kind() -> None:
    with pytest.raises(LayoutError, match="station 'x': unknown kind 'dock'"):
        Layout([Point("a", 0, 0)], [], [Station("x", "a", "dock")])  # type: ignore[arg-type]


def test_block_unknown_member() -> None:
    with pytest.raises(LayoutError, match="block 'B': unknown member 'nope'"):
        Layout([Point("a", 0, 0)], [], blocks={"B": ["a", "nope"]})


def one_way_pair(**kwargs: object) -> Layout:
    return Layout(
        [Point("a", 0, 0), Point("b", 5, 0)],
        [Segment("ab", "a", "b")],
        [Station("sa", "a"), Station("sb", "b")],
        **kwargs,  # type: ignore[arg-type]
    )


def test_unreachable_station_is_an_error() -> None:
    with pytest.raises(LayoutError, match="stations not mutually reachable: 'sb'"):
        one_way_pair()


def test_unreachable_station_can_be_tolerated_and_reported() -> None:
    layout = one_way_pair(require_connected_stations=False)
    assert layout.usable_stations() == ("sa",)
    assert layout.unreachable_stations() == ("sb",)


# -- queries ------------------------------------------------------------------------


def test_lookups_and_errors() -> None:
    layout = square()
    assert layout.point("b").xy == (10.0, 0.0)
    assert layout.station("s2").kind == "drop"
    assert layout.stations_at("a") == ("s1",)
    assert layout.stations_at("b") == ()
    assert [s.id for s in layout.stations_of_kind("pick", "drop")] == ["s1", "s2"]
    with pytest.raises(LayoutError, match="unknown point 'q'"):
        layout.point("q")
    with pytest.raises(LayoutError, match="unknown station 'q'"):
        layout.station("q")
    with pytest.raises(LayoutError, match="unknown segment 'q'"):
        layout.segment("q")
    assert "4 points" in repr(layout)


def test_bounds_include_via_vertices() -> None:
    assert square().bounds() == (-2.0, 0.0, 10.0, 10.0)
    with pytest.raises(LayoutError, match="no points"):
        Layout([], []).bounds()


def test_neighbours_and_direction() -> None:
    layout = square()
    assert layout.neighbours("b") == ("a", "c")
    assert layout.successors("b") == ("c",)
    assert layout.successors("c") == ("b", "d")
    assert layout.is_bidirectional("c", "b")
    assert not layout.is_bidirectional("a", "b")
    assert not layout.is_bidirectional("a", "c")
    assert layout.segment_between("b", "a") is None


def test_route_respects_one_way_segments() -> None:
    layout = square()
    # b -> a is one-way the other way round, so the route goes all the way round.
    r = layout.route("b", "a")
    assert r.points == ("b", "c", "d", "a")
    assert r.segments == ("bc", "cd", "da")
    da = 2 * math.hypot(2, 5)
    assert r.length == pytest.approx(20 + da)
    assert r.polyline.coords[-2] == (-2.0, 5.0)
    assert r.offsets == pytest.approx((0.0, 10.0, 20.0, 20 + da))
    assert layout.distance("b", "a") == pytest.approx(r.length)
    assert layout.route_length(["b", "c"]) == 10.0
    assert layout.route_polyline(["c", "b"]) == ((10.0, 10.0), (10.0, 0.0))


def test_route_to_self_is_a_single_point() -> None:
    r = square().route("c", "c")
    assert r.points == ("c",)
    assert r.length == 0.0
    assert r.index_at(5.0) == 0


def test_no_route() -> None:
    layout = Layout([Point("a", 0, 0), Point("b", 1, 0)], [Segment("s", "a", "b")])
    with pytest.raises(NoRouteError, match="no route from point 'b' to point 'a'"):
        layout.route("b", "a")
    assert layout.distance("b", "a") == math.inf


def test_route_through_rejects_wrong_direction() -> None:
    with pytest.raises(LayoutError, match="no segment drivable from point 'b' to point 'a'"):
        square().route_through(["b", "a"])
    with pytest.raises(LayoutError, match="at least one point"):
        square().route_through([])


def test_equal_routes_are_tie_broken_by_point_id() -> None:
    # Two routes of equal length from s to t: via "m1" or via "m2".
    def build(order: list[str]) -> Layout:
        pts = {"s": Point("s", 0, 0), "t": Point("t", 2, 0), "m1": Point("m1", 1, 1)}
        pts["m2"] = Point("m2", 1, -1)
        segs = [
            Segment("s-m1", "s", "m1"),
            Segment("m1-t", "m1", "t"),
            Segment("s-m2", "s", "m2"),
            Segment("m2-t", "m2", "t"),
        ]
        return Layout([pts[k] for k in order], segs if order[0] == "s" else segs[::-1])

    a = build(["s", "t", "m1", "m2"]).shortest_path("s", "t")
    b = build(["m2", "m1", "t", "s"]).shortest_path("s", "t")
    assert a == b == ("s", "m1", "t")


def test_index_at() -> None:
    r = square().route("a", "d")
    assert [r.index_at(s) for s in (0.0, 9.9, 10.0, 25.0, 30.0, 99.0)] == [0, 0, 1, 2, 3, 3]


# -- passing places -------------------------------------------------------------------


def corridor() -> Layout:
    """A bidirectional corridor j1 - c1 - c2 - j2 between two junctions, a one-way exit.

    x0 -> j1 <- x1 ; j1 <-> c1 <-> c2 <-> j2 ; j2 -> y0, y1 -> j2; c2 has a mid-corridor station.
    """
    pts = [
        Point("x0", -5, 1),
        Point("x1", -5, -1),
        Point("j1", 0, 0),
        Point("c1", 5, 0),
        Point("c2", 10, 0),
        Point("j2", 15, 0),
        Point("y0", 20, 1),
        Point("y1", 20, -1),
        Point("lay", 5, 3, passing=True),
    ]
    segs = [
        Segment("x0j1", "x0", "j1"),
        Segment("j1x1", "j1", "x1"),
        Segment("x1x0", "x1", "x0"),
        Segment("j1c1", "j1", "c1", bidirectional=True),
        Segment("c1c2", "c1", "c2", bidirectional=True),
        Segment("c2j2", "c2", "j2", bidirectional=True),
        Segment("j2y0", "j2", "y0"),
        Segment("y1j2", "y1", "j2"),
        Segment("y0y1", "y0", "y1"),
        Segment("c1lay", "c1", "lay", bidirectional=True),
    ]
    return Layout(pts, segs, [Station("mid", "c2"), Station("end", "y0")])


def test_passing_place_rule() -> None:
    layout = corridor()
    # j1, j2: three neighbours; c1: three (j1, c2, lay); lay: dead end and marked.
    assert layout.passing_places() == frozenset({"j1", "j2", "c1", "lay"})
    # A station in mid-corridor is not a place to get out of the way.
    assert not layout.is_passing_place("c2")


def test_passing_extent_covers_the_bidirectional_run() -> None:
    layout = corridor()
    r = layout.route_through(["x0", "j1", "c1", "c2", "j2", "y0"])
    assert layout.passing_extent(r, 0).index == 1  # one-way: to its end
    assert not layout.passing_extent(r, 0).bidirectional
    assert layout.passing_extent(r, 1).index == 2  # j1 -> c1 ends at junction c1
    ext = layout.passing_extent(r, 2)  # c1 -> c2 -> j2: c2 is no passing place
    assert (ext.index, ext.s, ext.bidirectional) == (4, r.offsets[4], True)
    assert layout.next_passing_place(r, 2) == 4
    assert layout.next_passing_place(r, 4) is None
    with pytest.raises(LayoutError, match="segment index 5 outside route"):
        layout.passing_extent(r, 5)


def test_passing_extent_stops_at_route_end() -> None:
    layout = corridor()
    r = layout.route_through(["c1", "c2"])
    assert layout.passing_extent(r, 0).index == 1


def test_blocks_are_kept() -> None:
    layout = Layout(
        [Point("a", 0, 0), Point("b", 1, 0)],
        [Segment("s", "a", "b", bidirectional=True)],
        [Station("st", "a")],
        blocks={"B": ["s", "a", "st"]},
    )
    assert layout.blocks["B"] == frozenset({"s", "a", "st"})


def test_layout_is_read_only() -> None:
    layout = square()
    with pytest.raises(TypeError):
        layout.points["z"] = Point("z", 0, 0)  # type: ignore[index]
    with pytest.raises(AttributeError):
        layout.spam = 1  # type: ignore[attr-defined]
