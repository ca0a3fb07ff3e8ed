"""A projection's spine, and the overlaps a probe proves with it.

A hull projection knows its path lies half a hull width inside it (``Area.spine``); a
probe that finds a point of another area's spine deep inside its own area says
"overlap" without working out the intersection. The answers must be the plain ones.
"""

from __future__ import annotations

import math

import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from agv_app.geometry import Area, Polyline, hull_projection, overlaps, projection_ahead
from agv_app.geometry import probe as probe_module
from agv_app.geometry.probe import Probe
from agv_app.geometry.wire import coords_to_polygon
from agv_app.traffic.collision import request_coords

coord = st.floats(-15, 15, allow_nan=False)
routes = st.lists(st.tuples(coord, coord), min_size=1, max_size=4)
sizes = st.tuples(st.floats(0.2, 3.0), st.floats(0.2, 2.0))


def _projection(
    points: list[tuple[float, float]], f0: float, f1: float, size: tuple[float, float]
) -> Area:
    line = Polyline(points)
    a, b = sorted((f0 * line.length, f1 * line.length))
    return hull_projection(line, a, b, length=size[0], width=size[1])


@settings(max_examples=80, deadline=None)
@given(routes, st.floats(0, 1), st.floats(0, 1), sizes)
def test_the_spine_lies_its_clearance_inside_the_projection(
    points: list[tuple[float, float]], f0: float, f1: float, size: tuple[float, float]
) -> None:
    area = _projection(points, f0, f1, size)
    spine = area.spine
    assert spine is not None
    assert spine.clearance == pytest.approx(min(size) / 2)
    # The disc drawn inside the true one (chords), slightly smaller: inside the area.
    deep = spine.geom.buffer(spine.clearance * 0.99, quad_segs=8)
    assert area.geom.buffer(1e-9).contains(deep)


@settings(max_examples=150, deadline=None)
@given(
    routes,
    st.floats(0, 1),
    st.floats(0, 1),
    sizes,
    st.lists(st.tuples(routes, st.floats(0, 1), st.floats(0, 1), sizes), min_size=1, max_size=4),
    st.booleans(),
)
def test_a_probe_answers_as_the_plain_overlap(
    points: list[tuple[float, float]],
    f0: float,
    f1: float,
    size: tuple[float, float],
    others: list[tuple[list[tuple[float, float]], float, float, tuple[float, float]]],
    wire: bool,
) -> None:
    request = _projection(points, f0, f1, size)
    if wire:  # as a voter gets it: grown, simplified, without a spine
        request = coords_to_polygon(request_coords(request))
    probe = Probe(request)
    for route, g0, g1, other_size in others:
        lock = _projection(route, g0, g1, other_size)
        assert probe.overlaps(lock) == overlaps(request, lock)


def test_a_lock_whose_path_runs_through_the_request_is_an_overlap_without_an_intersection(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    request = _projection([(0.0, 0.0), (10.0, 0.0)], 0.0, 1.0, (1.5, 1.0))
    lock = projection_ahead(Polyline([(5.0, -5.0), (5.0, 5.0)]), 2.0, 8.0, length=1.5, width=1.0)

    def plain(*_: object, **__: object) -> bool:
        raise AssertionError("the spine proves it")

    monkeypatch.setattr(probe_module, "overlaps", plain)
    assert Probe(request).overlaps(lock)


def test_no_proof_from_a_spine_that_stays_outside_or_an_area_without_one() -> None:
    request = Probe(_projection([(0.0, 0.0), (10.0, 0.0)], 0.0, 1.0, (1.5, 1.0)))
    # Hulls reaching into the request's edge (0.2 m), their path outside it.
    grazing = _projection([(0.0, 0.8), (10.0, 0.8)], 0.0, 1.0, (1.5, 1.0))
    assert not request._surely_overlaps(grazing)
    assert request.overlaps(grazing)
    plain = Area(shapely.box(4.0, -1.0, 6.0, 1.0))
    assert plain.spine is None
    assert not request._surely_overlaps(plain)
    assert request.overlaps(plain)
    assert math.isclose(shapely.intersection(request.area.geom, plain.geom).area, 2.0)
