"""Layout graph: validation errors, routing, passing places, station reachability."""

from __future__ import annotations

import copy
import json
import math
import re
from pathlib import Path
from typing import Any

import pytest

from agv_app.geometry import Area, Polyline, hull, hull_projection, overlaps
from agv_app.layout import (
    Layout,
    LayoutError,
    LayoutFileError,
    NoRouteError,
    Point,
    Segment,
    Station,
)
from agv_app.layout.demo import DEMO_VEHICLE_LENGTH_M, DEMO_VEHICLE_WIDTH_M, demo_warehouse
from agv_app.layout.graph import MAX_FLOOR_COORDINATE_M
from agv_app.layout.json_format import (
    layout_from_json,
    layout_schema,
    layout_to_json,
    load_any,
    load_layout,
    save_layout,
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


def test_a_point_or_vertex_beyond_the_floor_bound() -> None:
    far = MAX_FLOOR_COORDINATE_M * 1.5
    with pytest.raises(LayoutError, match=r"point 'b': position .* lies beyond"):
        Layout([Point("a", 0, 0), Point("b", 0, far)], [Segment("s", "a", "b")])
    with pytest.raises(LayoutError, match=r"segment 's': via vertex .* lies beyond"):
        Layout(
            [Point("a", 0, 0), Point("b", 4, 0)],
            [Segment("s", "a", "b", via=((-far, 1.0),))],
        )
    edge = Layout([Point("a", 0, 0), Point("b", MAX_FLOOR_COORDINATE_M, 0)], [])
    assert edge.bounds()[2] == MAX_FLOOR_COORDINATE_M


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


def test_a_route_may_avoid_segments() -> None:
    # a -> b -> c directly, or round the long way when b -> c is to be avoided.
    layout = Layout(
        [Point("a", 0, 0), Point("b", 10, 0), Point("c", 20, 0), Point("d", 10, 10)],
        [
            Segment("ab", "a", "b"),
            Segment("bc", "b", "c"),
            Segment("bd", "b", "d"),
            Segment("dc", "d", "c"),
        ],
    )
    assert layout.route("a", "c").points == ("a", "b", "c")
    detour = layout.route_avoiding("a", "c", {"bc"})
    assert detour.points == ("a", "b", "d", "c")
    assert detour.segments == ("ab", "bd", "dc")
    assert layout.route("a", "c").points == ("a", "b", "c")  # the cached search unharmed
    with pytest.raises(NoRouteError, match="no route from point 'a' to point 'c'"):
        layout.route_avoiding("a", "c", {"bc", "dc"})


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


# -- JSON format ------------------------------------------------------------------------

GOOD: dict[str, Any] = {
    "format": "objectplaces-layout",
    "version": 1,
    "name": "tiny",
    "points": [
        {"id": "a", "x": 0, "y": 0},
        {"id": "b", "x": 10, "y": 0},
        {"id": "c", "x": 10, "y": 5, "passing": True},
    ],
    "segments": [
        {"id": "ab", "start": "a", "end": "b", "bidirectional": True},
        {"id": "bc", "start": "b", "end": "c", "via": [[12, 2.5]]},
        {"id": "ca", "start": "c", "end": "a"},
    ],
    "stations": [{"id": "s1", "point": "a", "kind": "pick"}, {"id": "s2", "point": "c"}],
    "blocks": {"B": ["ab", "c"]},
}


def test_json_roundtrip(tmp_path: Path) -> None:
    layout = layout_from_json(GOOD)
    assert layout.name == "tiny"
    assert layout.station("s2").kind == "pickdrop"
    assert layout.segment("bc").via == ((12.0, 2.5),)
    assert layout.is_passing_place("c")
    path = tmp_path / "tiny.json"
    save_layout(layout, path)
    again = load_layout(path)
    assert layout_to_json(again) == layout_to_json(layout)
    assert layout_to_json(again)["segments"][0] == GOOD["segments"][0]
    assert load_any(path).name == "tiny"


def test_demo_roundtrips_through_json() -> None:
    demo = demo_warehouse()
    doc = json.loads(json.dumps(layout_to_json(demo)))
    assert layout_to_json(layout_from_json(doc)) == layout_to_json(demo)


def test_docs_example_loads() -> None:
    text = (Path(__file__).parents[3] / "docs" / "layout-format.md").read_text()
    example = text.split("```json", 1)[1].split("```", 1)[0]
    layout = layout_from_json(json.loads(example))
    assert len(layout.stations) >= 2


def test_schema_is_valid_draft_2020_12() -> None:
    import jsonschema

    jsonschema.Draft202012Validator.check_schema(dict(layout_schema()))


def broken(path: str, value: object) -> dict[str, Any]:
    """GOOD with the element at a dotted path replaced (or deleted if value is ...)."""
    doc = copy.deepcopy(GOOD)
    *keys, last = path.split(".")
    node: Any = doc
    for k in keys:
        node = node[int(k)] if k.isdigit() else node[k]
    key: Any = int(last) if last.isdigit() else last
    if value is ...:
        del node[key]
    else:
        node[key] = value
    return doc


@pytest.mark.parametrize(
    ("doc", "where", "message"),
    [
        (broken("format", "svg"), "$.format", "'objectplaces-layout' was expected"),
        (broken("version", 2), "$.version", "1 was expected"),
        (broken("points", ...), "$", "'points' is a required property"),
        (broken("points.1.x", "ten"), "$.points[1].x", "'ten' is not of type 'number'"),
        (broken("segments.0.colour", "red"), "$.segments[0]", "Additional properties"),
        (broken("segments.1.via", [[1, 2, 3]]), "$.segments[1].via[0]", "is too long"),
        (broken("stations.1.kind", "dock"), "$.stations[1].kind", "'dock' is not one of"),
        (broken("points.1.id", ""), "$.points[1].id", "should be non-empty"),
        (broken("points.1.id", "a"), "$.points[1].id", "duplicate point id 'a'"),
        (broken("segments.1.id", "ab"), "$.segments[1].id", "duplicate segment id 'ab'"),
        (
            broken("segments.1.end", "zz"),
            "$.segments[1].end",
            "segment 'bc': unknown end point 'zz'",
        ),
        (
            broken("segments.0.start", "zz"),
            "$.segments[0].start",
            "segment 'ab': unknown start point 'zz'",
        ),
        (
            broken("points.1.x", 0),
            "$.segments[0]",
            "segment 'ab': zero length between vertices 0 and 1",
        ),
        (
            broken("segments.1.via", [[10, 0]]),
            "$.segments[1]",
            "segment 'bc': zero length between vertices 0 and 1",
        ),
        (broken("stations.1.id", "s1"), "$.stations[1].id", "duplicate station id 's1'"),
        (
            broken("stations.1.point", "q"),
            "$.stations[1].point",
            "station 's2': unknown point 'q'",
        ),
        (
            broken("blocks.B", ["ab", "nope"]),
            "$.blocks['B'][1]",
            "block 'B': unknown member 'nope'",
        ),
        (
            broken("segments.2", {"id": "ac", "start": "a", "end": "c"}),
            "$.stations",
            "stations not mutually reachable",
        ),
        (
            broken("segments.2", {"id": "bc2", "start": "b", "end": "c"}),
            "$",
            "segment 'bc2': 'b' -> 'c' is already served by segment 'bc'",
        ),
    ],
)
def test_json_errors_name_the_path(doc: dict[str, Any], where: str, message: str) -> None:
    with pytest.raises(LayoutFileError, match=re.escape(message)) as exc:
        layout_from_json(doc)
    assert exc.value.where == where
    assert str(exc.value).startswith(where + ": ")


def test_json_file_errors(tmp_path: Path) -> None:
    with pytest.raises(LayoutFileError, match="cannot read layout file"):
        load_layout(tmp_path / "missing.json")
    bad = tmp_path / "bad.json"
    bad.write_text('{"format": ')
    with pytest.raises(LayoutFileError, match="not valid JSON") as exc:
        load_layout(bad)
    assert exc.value.where == "line 1 column 12"
    bad.write_text(json.dumps(GOOD).replace('"x": 10', '"x": NaN', 1))
    with pytest.raises(LayoutFileError, match="NaN is not a number"):
        load_layout(bad)
    huge = json.dumps(GOOD).replace('"x": 10', '"x": 1e999', 1)
    bad.write_text(huge)
    with pytest.raises(LayoutFileError, match="point 'b': non-finite position"):
        load_layout(bad)
    bad.write_text(json.dumps(GOOD).replace('"x": 10', '"x": 1e300', 1))
    with pytest.raises(LayoutFileError, match=r"point 'b': position .* lies beyond"):
        load_layout(bad)
    # A whole number of 400 digits is a JSON number too: refused, never an overflow.
    bad.write_text(json.dumps(GOOD).replace('"x": 10', '"x": 1' + "0" * 400, 1))
    with pytest.raises(LayoutFileError, match=r"\(401 characters\) lies beyond") as exc:
        load_layout(bad)
    assert exc.value.where == "$.points[1].x"


def test_layout_without_name_takes_file_stem(tmp_path: Path) -> None:
    doc = copy.deepcopy(GOOD)
    del doc["name"]
    path = tmp_path / "hall-7.json"
    path.write_text(json.dumps(doc))
    assert load_layout(path).name == "hall-7"


# -- demo warehouse ---------------------------------------------------------------------


def test_demo_warehouse_shape() -> None:
    demo = demo_warehouse()
    x0, y0, x1, y1 = demo.bounds()
    assert 50 <= x1 - x0 <= 62
    assert 30 <= y1 - y0 <= 42
    kinds = [s.kind for s in demo.stations.values()]
    assert kinds.count("pick") + kinds.count("drop") + kinds.count("pickdrop") >= 12
    assert kinds.count("parking") + kinds.count("charging") >= 200
    assert kinds.count("charging") >= 4
    assert demo.unreachable_stations() == ()
    assert any(s.bidirectional for s in demo.segments.values())
    assert any(not s.bidirectional for s in demo.segments.values())
    # Every station sits on its own dead-end spur, a passing place.
    for st in demo.stations.values():
        assert len(demo.neighbours(st.point)) == 1
        assert demo.is_passing_place(st.point)


def test_demo_parked_vehicles_never_block_traffic() -> None:
    """A vehicle at any station touches no lane traffic and no other station's vehicle."""
    demo = demo_warehouse()
    length, width = DEMO_VEHICLE_LENGTH_M, DEMO_VEHICLE_WIDTH_M
    spots = {st.point for st in demo.stations.values()}
    parked: dict[str, Area] = {}
    for pid in spots:
        (base,) = demo.neighbours(pid)
        poly = Polyline([demo.point(base).xy, demo.point(pid).xy])
        parked[pid] = hull_projection(poly, poly.length, poly.length, length=length, width=width)
    radius = math.hypot(length / 2, width / 2)
    traffic: list[Area] = []
    for seg in demo.segments.values():
        if seg.start in spots or seg.end in spots:
            continue
        poly = Polyline(demo.segment_coords(seg.id))
        traffic.append(hull_projection(poly, 0, poly.length, length=length, width=width))
    import shapely

    lanes = {p for s in demo.segments.values() for p in (s.start, s.end)} - spots
    # Any turn at a lane point stays within the half-diagonal circle.
    turns = [Area(shapely.Point(demo.point(p).xy).buffer(radius)) for p in sorted(lanes)]
    floor = Area.union_of(traffic + turns)
    for pid, area in parked.items():
        assert not overlaps(area, floor), pid
    ordered = sorted(parked)
    tree = shapely.STRtree([parked[p].geom for p in ordered])
    for i, pid in enumerate(ordered):
        for j in tree.query(parked[pid].geom):
            if j != i:
                assert not overlaps(parked[pid], parked[ordered[j]]), (pid, ordered[j])
    # Driving into a spur never touches the vehicle parked on the next one.
    for pid in ordered:
        (base,) = demo.neighbours(pid)
        poly = Polyline([demo.point(base).xy, demo.point(pid).xy])
        entering = hull_projection(poly, 0, poly.length, length=length, width=width)
        for j in tree.query(entering.geom):
            if ordered[j] != pid:
                assert not overlaps(entering, parked[ordered[j]]), (pid, ordered[j])


def test_demo_routes_are_fast_and_deterministic() -> None:
    a, b = demo_warehouse(), demo_warehouse()
    ids = sorted(a.stations)
    for s in ids[::17]:
        for t in ids[::23]:
            pa, pb = a.station(s).point, a.station(t).point
            assert a.shortest_path(pa, pb) == b.shortest_path(pa, pb)
    stand_still = hull(
        a.route(a.station(ids[0]).point, a.station(ids[0]).point).polyline.pose_at(0),
        length=2,
        width=1,
    )
    assert stand_still.area_m2 == pytest.approx(2.0)
