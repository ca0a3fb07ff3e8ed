"""The safety monitor's candidate pairs are exactly those of comparing every box with
every other: the R-tree only saves work, it never loses or adds a pair."""

from __future__ import annotations

import shapely
from hypothesis import given
from hypothesis import strategies as st

from agv_app.geometry import Area
from agv_app.geometry.area import Pose
from agv_app.geometry.projection import hull
from agv_app.traffic.monitor import SafetyMonitor, _pairs


def _all_pairs(items: list[tuple[str, Area]]) -> list[tuple[int, int]]:
    """The definition: i < j, different owners, boxes overlap strictly (NaN: never)."""
    found = []
    for i, (a, ga) in enumerate(items):
        for j in range(i + 1, len(items)):
            b, gb = items[j]
            ax0, ay0, ax1, ay1 = ga.bounds
            bx0, by0, bx1, by1 = gb.bounds
            if a != b and ax0 < bx1 and bx0 < ax1 and ay0 < by1 and by0 < ay1:
                found.append((i, j))
    return found


_box = st.one_of(
    st.just(None),
    st.tuples(
        st.sampled_from([0.0, 0.5, 1.0, 2.0, 2.5]),
        st.sampled_from([0.0, 1.0, 2.0]),
        st.sampled_from([0.0, 0.5, 1.0]),
        st.sampled_from([0.5, 1.0]),
    ),
)


@given(st.lists(st.tuples(st.sampled_from("abcd"), _box), max_size=25))
def test_pairs_are_the_all_pairs_comparison(
    boxes: list[tuple[str, tuple[float, float, float, float] | None]],
) -> None:
    items = [
        (
            owner,
            Area.empty()
            if box is None
            else Area(shapely.box(box[0], box[1], box[0] + box[2], box[1] + box[3])),
        )
        for owner, box in boxes
    ]
    assert _pairs(items) == _all_pairs(items)


def test_monitor_counts_a_collision_among_many_apart() -> None:
    hulls = [(f"agv-{k}", hull(Pose(3.0 * k, 0.0, 0.0), length=1.0, width=0.5)) for k in range(200)]
    hulls.append(("agv-x", hull(Pose(300.2, 0.0, 0.0), length=1.0, width=0.5)))
    monitor = SafetyMonitor()
    found = monitor.check(1, 0.1, hulls, [])
    assert [v.agvs for v in found] == [("agv-100", "agv-x")]
    assert monitor.collisions == 1
