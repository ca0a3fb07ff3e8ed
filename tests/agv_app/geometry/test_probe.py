"""Probe: the same answers as ``overlaps`` and ``hull_length``, remembered."""

from __future__ import annotations

import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from agv_app.geometry import Area, hull_length, overlaps
from agv_app.geometry.probe import Probe


def box(x0: float, y0: float, x1: float, y1: float) -> Area:
    return Area(shapely.box(x0, y0, x1, y1))


coords = st.floats(-20, 20, allow_nan=False)


@settings(max_examples=60, deadline=None)
@given(coords, coords, coords, coords, st.lists(st.tuples(coords, coords), min_size=1, max_size=6))
def test_probe_answers_as_the_functions_do(
    x: float, y: float, w: float, h: float, others: list[tuple[float, float]]
) -> None:
    area = box(x, y, x + abs(w) + 0.1, y + abs(h) + 0.1)
    probe = Probe(area)
    tested = [box(ox, oy, ox + 3.0, oy + 2.0) for ox, oy in others]
    for _ in range(2):  # the second round is answered from memory
        for other in tested:
            assert probe.overlaps(other) == overlaps(area, other)
        for ox, oy in others:
            assert probe.hull_length((ox, oy)) == hull_length((ox, oy), [area])


def test_probe_of_an_empty_area() -> None:
    probe = Probe(Area.empty())
    assert probe.hull_length((1.0, 2.0)) == 0.0
    assert not probe.overlaps(box(0, 0, 1, 1))


def test_probe_remembers_per_object_not_per_id_alone() -> None:
    probe = Probe(box(0, 0, 2, 2))
    assert probe.overlaps(box(1, 1, 3, 3))
    # A new object may get the id of a collected one: its answer is worked out anew.
    for _ in range(100):
        assert not probe.overlaps(box(5, 5, 6, 6))
    assert probe.overlaps(box(1, 1, 3, 3))


def test_an_area_remembers_its_extent_and_overlaps_as_before() -> None:
    a = box(0, 0, 2, 2)
    assert a.extent() == a.bounds == (0.0, 0.0, 2.0, 2.0)
    assert a.extent() is a.extent()
    assert Area.empty().extent() == ()
    assert not overlaps(Area.empty(), a)
    assert not overlaps(a, Area.empty())
    assert not overlaps(a, box(2, 0, 3, 2))  # touching edges
    assert overlaps(a, box(1, 1, 3, 3))
