"""Geometry: polylines, hull projections (fast vs naive), release, wire form, overlaps."""

from __future__ import annotations

import math

import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from agv_app.geometry import (
    WIRE_MARGIN_M,
    Area,
    Polyline,
    Pose,
    coords_to_polygon,
    hull,
    hull_length,
    hull_projection,
    hull_projection_sampled,
    overlaps,
    polygon_to_coords,
    projection_ahead,
)

L, W = 2.0, 1.0

coord = st.floats(-30, 30, allow_nan=False).map(lambda v: round(v, 1))
polylines = st.lists(st.tuples(coord, coord), min_size=2, max_size=5).map(Polyline)


# -- Polyline ---------------------------------------------------------------------------


def test_polyline_basics() -> None:
    p = Polyline([(0, 0), (3, 4), (3, 4), (3, 10)])
    assert p.coords == ((0.0, 0.0), (3.0, 4.0), (3.0, 10.0))  # duplicate dropped
    assert p.cumulative == (0.0, 5.0, 11.0)
    assert p.length == 11.0
    assert p.point_at(2.5) == pytest.approx((1.5, 2.0))
    assert p.point_at(-1) == (0.0, 0.0)
    assert p.point_at(99) == (3.0, 10.0)
    assert p.heading_at(0) == pytest.approx(math.atan2(4, 3))
    # On a vertex the vehicle still faces the piece it arrived on.
    assert p.heading_at(5.0) == pytest.approx(math.atan2(4, 3))
    assert p.heading_at(5.0001) == pytest.approx(math.pi / 2)
    pose = p.pose_at(11)
    assert (pose.x, pose.y, pose.heading_rad) == pytest.approx((3.0, 10.0, math.pi / 2))
    assert p.vertex_arclengths() == (5.0,)


def test_polyline_slice() -> None:
    p = Polyline([(0, 0), (10, 0), (10, 10)])
    s = p.slice(5, 15)
    assert s.coords == ((5.0, 0.0), (10.0, 0.0), (10.0, 5.0))
    assert s.length == 10.0
    assert p.slice(3, 3).length == 0.0
    assert p.slice(3, 3).heading_at(0) == 0.0
    with pytest.raises(ValueError, match="before start"):
        p.slice(5, 4)


def test_polyline_rejects_bad_input() -> None:
    with pytest.raises(ValueError, match="at least one vertex"):
        Polyline([])
    with pytest.raises(ValueError, match="non-finite"):
        Polyline([(0, 0), (math.inf, 0)])


def test_single_point_polyline() -> None:
    p = Polyline([(1, 2)], heading_rad=1.0)
    assert p.length == 0.0
    assert p.pose_at(5) == Pose(1.0, 2.0, 1.0)
    assert hull_projection(p, 0, 0, length=L, width=W).area_m2 == pytest.approx(2.0)


@given(polylines, st.floats(0, 1), st.floats(0, 1))
def test_slice_matches_point_at(p: Polyline, f0: float, f1: float) -> None:
    s0, s1 = sorted((f0 * p.length, f1 * p.length))
    part = p.slice(s0, s1)
    assert part.length == pytest.approx(s1 - s0, abs=1e-9)
    for t in (0.0, 0.5, 1.0):
        x, y = part.point_at(t * part.length)
        ex, ey = p.point_at(s0 + t * part.length)
        assert x == pytest.approx(ex, abs=1e-9)
        assert y == pytest.approx(ey, abs=1e-9)


# -- hulls and projections -----------------------------------------------------------


def test_hull_is_centred_rectangle() -> None:
    h = hull(Pose(5, 5, math.pi / 2), length=L, width=W)
    assert h.bounds == pytest.approx((4.5, 4.0, 5.5, 6.0))
    assert h.area_m2 == pytest.approx(2.0)


def test_straight_projection_is_one_rectangle() -> None:
    p = Polyline([(0, 0), (10, 0)])
    a = hull_projection(p, 2, 7, length=L, width=W)
    assert a.bounds == pytest.approx((1.0, -0.5, 8.0, 0.5))
    assert a.area_m2 == pytest.approx(7.0)


def test_turn_sweeps_the_corner() -> None:
    p = Polyline([(0, 0), (10, 0), (10, 10)])
    a = hull_projection(p, 8, 12, length=L, width=W)
    radius = math.hypot(L / 2, W / 2)
    # Turning left at (10, 0), the rear corner swings out to the south-west.
    diag = (10 - radius * math.cos(math.pi / 4), -radius * math.sin(math.pi / 4))
    assert a.distance_to(diag) < 1e-6
    # Stopping on the vertex: no turn yet, so the hull still faces east.
    b = hull_projection(p, 8, 10, length=L, width=W)
    assert b.bounds == pytest.approx((7.0, -0.5, 11.0, 0.5))


def test_projection_argument_errors() -> None:
    p = Polyline([(0, 0), (10, 0)])
    with pytest.raises(ValueError, match="before start"):
        hull_projection(p, 5, 4, length=L, width=W)
    with pytest.raises(ValueError, match="positive length and width"):
        hull_projection(p, 0, 4, length=0, width=W)
    with pytest.raises(ValueError, match="step must be positive"):
        hull_projection(p, 0, 4, length=L, width=W, step=0)
    with pytest.raises(ValueError, match="before start"):
        hull_projection_sampled(p, 5, 4, length=L, width=W)


@settings(max_examples=60, deadline=None)
@given(polylines, st.floats(0, 1), st.floats(0, 1))
def test_fast_projection_equals_naive_union(p: Polyline, f0: float, f1: float) -> None:
    s0, s1 = sorted((f0 * p.length, f1 * p.length))
    fast = hull_projection(p, s0, s1, length=L, width=W, step=0.25)
    naive = hull_projection_sampled(p, s0, s1, length=L, width=W, step=0.25)
    # The fast one is the exact sweep; the naive copies leave notches between them
    # (a rectangle's corner is sharp), so the fast one may only be larger, by a
    # bounded amount per radian turned.
    assert fast.contains(naive, tolerance_m=1e-7)
    turned = sum(
        abs(math.remainder(p.piece_heading(v) - p.piece_heading(v - 1), math.tau))
        for v in range(1, len(p.coords) - 1)
        if s0 <= p.cumulative[v] < s1
    )
    assert fast.area_m2 - naive.area_m2 <= 0.1 * turned + 1e-7


def test_naive_projection_converges_to_fast_one() -> None:
    p = Polyline([(0, 0), (6, 0), (6, 5), (0, 5)])  # two left turns
    for step, gap in ((0.25, 0.3), (0.05, 0.07), (0.01, 0.015)):  # shrinks with the step
        fast = hull_projection(p, 1, 15, length=L, width=W, step=step)
        naive = hull_projection_sampled(p, 1, 15, length=L, width=W, step=step)
        assert fast.contains(naive, tolerance_m=1e-9)
        assert fast.area_m2 - naive.area_m2 < gap


@settings(max_examples=60, deadline=None)
@given(polylines, st.floats(0, 1), st.floats(0, 1), st.floats(0, 1))
def test_release_only_shrinks(p: Polyline, f0: float, f1: float, f2: float) -> None:
    s0, s_now, end = sorted((f0 * p.length, f1 * p.length, f2 * p.length))
    lock = hull_projection(p, s0, end, length=L, width=W)
    ahead = projection_ahead(p, s_now, end, length=L, width=W)
    assert lock.contains(ahead, tolerance_m=1e-7)
    # The vehicle's own hull is always inside what it keeps.
    assert ahead.contains(hull(p.pose_at(s_now), length=L, width=W), tolerance_m=1e-7)


def test_release_cuts_away_driven_part() -> None:
    p = Polyline([(0, 0), (20, 0)])
    lock = hull_projection(p, 0, 15, length=L, width=W)
    ahead = projection_ahead(p, 10, 15, length=L, width=W)
    assert ahead.bounds == pytest.approx((9.0, -0.5, 16.0, 0.5))
    assert lock.difference(ahead).area_m2 == pytest.approx(10.0)
    # Past the end of the lock: only the hull where the vehicle stands.
    assert projection_ahead(p, 16, 15, length=L, width=W).area_m2 == pytest.approx(2.0)


# -- hull length ----------------------------------------------------------------------


def test_hull_length() -> None:
    assert hull_length((0, 0), []) == 0.0
    assert hull_length((0, 0), [Area.empty()]) == 0.0
    p = Polyline([(0, 0), (10, 0)])
    a = hull_projection(p, 0, 10, length=L, width=W)
    assert hull_length((0, 0), [a]) == pytest.approx(math.hypot(11, 0.5))
    b = hull(Pose(-5, 0, 0), length=L, width=W)
    assert hull_length((0, 0), [a, b]) == pytest.approx(math.hypot(11, 0.5))


# -- overlap ---------------------------------------------------------------------------


def test_touching_is_not_overlapping() -> None:
    a = hull(Pose(0, 0, 0), length=L, width=W)
    b = hull(Pose(2, 0, 0), length=L, width=W)  # bumper to bumper
    assert not overlaps(a, b)
    c = hull(Pose(1.99, 0, 0), length=L, width=W)  # 1 cm into each other
    assert overlaps(a, c)
    assert a.overlaps(c)
    far = hull(Pose(50, 0, 0), length=L, width=W)
    assert not overlaps(a, far)
    assert not overlaps(a, Area.empty())


def test_overlap_tolerance_ignores_slivers() -> None:
    a = hull(Pose(0, 0, 0), length=L, width=W)
    sliver = hull(Pose(2 - 1e-7, 0, 0), length=L, width=W)  # 1e-7 m deep
    assert not overlaps(a, sliver)
    assert overlaps(a, sliver, tolerance_m2=0.0)


# -- wire form ---------------------------------------------------------------------------


def test_wire_roundtrip_is_compact_and_rounded() -> None:
    a = hull(Pose(1.234, 5.678, 0.3), length=L, width=W)
    coords = polygon_to_coords(a, margin_m=0)
    assert [len(polygon) for polygon in coords] == [1]
    assert len(coords[0][0]) == 8
    assert all(v == round(v, 2) for v in coords[0][0])
    back = coords_to_polygon(coords)
    assert back.area_m2 == pytest.approx(2.0, abs=0.03)
    assert coords_to_polygon([]).is_empty
    assert polygon_to_coords(Area.empty()) == []


def test_wire_multipolygon() -> None:
    a = hull(Pose(0, 0, 0), length=L, width=W).union(hull(Pose(10, 0, 0), length=L, width=W))
    coords = polygon_to_coords(a)
    assert len(coords) == 2
    assert coords_to_polygon(coords).contains(a)


def test_wire_rejects_bad_rings() -> None:
    with pytest.raises(ValueError, match="polygon 0 ring 0"):
        coords_to_polygon([[[0.0, 0.0, 1.0, 0.0]]])


@settings(max_examples=60, deadline=None)
@given(polylines, st.floats(0, 1), st.floats(0, 1))
def test_wire_form_never_shrinks(p: Polyline, f0: float, f1: float) -> None:
    s0, s1 = sorted((f0 * p.length, f1 * p.length))
    a = hull_projection(p, s0, s1, length=L, width=W)
    back = coords_to_polygon(polygon_to_coords(a))
    assert back.contains(a, tolerance_m=1e-9)
    assert back.area_m2 - a.area_m2 < 0.05 * (a.geom.length + 1)


def test_a_sliver_hole_at_a_sharp_turn_is_filled_on_the_wire() -> None:
    # Found by test_wire_form_never_shrinks: at this turn the union of the projection's
    # rectangles leaves a hole 1 mm round, which rounding collapsed into a ring of one
    # vertex, and every receiver refused the request.
    p = Polyline([(-13.3, -11.8), (0.0, -20.8), (0.0, 0.0)])
    a = hull_projection(p, 0.0, 0.5 * p.length, length=L, width=W)
    assert list(a.geom.buffer(WIRE_MARGIN_M, join_style="mitre").interiors)
    coords = polygon_to_coords(a)
    assert [len(rings) for rings in coords] == [1]
    assert coords_to_polygon(coords).contains(a, tolerance_m=1e-9)


def test_a_shape_too_small_for_centimetres_goes_as_its_box() -> None:
    tiny = Area(shapely.box(0.001, 0.001, 0.004, 0.003))
    coords = polygon_to_coords(tiny, margin_m=0)
    assert coords == [[[0.0, 0.0, 0.01, 0.0, 0.01, 0.01, 0.0, 0.01]]]
    assert coords_to_polygon(coords).contains(tiny)


def test_area_helpers() -> None:
    a = hull(Pose(0, 0, 0), length=L, width=W)
    assert "POLYGON" in repr(a)
    assert repr(Area.empty()) == "Area(EMPTY)"
    assert Area.union_of([]).is_empty
    assert Area.union_of([a, Area.empty()]).area_m2 == pytest.approx(2.0)
    assert a.intersection(a).area_m2 == pytest.approx(2.0)
    assert a.buffer(0.5).area_m2 == pytest.approx(2 * 3)
    assert a.contains_point((0.9, 0.4))
    assert not a.contains_point((1.1, 0))
    assert a.contains(Area.empty())
    assert math.isnan(Area.empty().bounds[0])
    with pytest.raises(AttributeError, match="immutable"):
        a.geom = None


def test_collinear_pieces_make_one_rectangle() -> None:
    p = Polyline([(0, 0), (1.25, 0), (2.5, 0), (3.75, 0), (10, 0)])
    a = hull_projection(p, 0.5, 9, length=L, width=W)
    assert len(a.geom.exterior.coords) == 5
    assert a.bounds == pytest.approx((-0.5, -0.5, 10.0, 0.5))
    naive = hull_projection_sampled(p, 0.5, 9, length=L, width=W)
    assert a.geom.symmetric_difference(naive.geom).area < 1e-9
