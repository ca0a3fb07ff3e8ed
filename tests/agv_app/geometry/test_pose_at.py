"""``Polyline.pose_at`` in one pass against its plain form, ``point_at`` and ``heading_at``."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from agv_app.geometry.area import Pose
from agv_app.geometry.polyline import Polyline

POINTS = st.tuples(st.floats(-50.0, 50.0), st.floats(-50.0, 50.0))


@given(
    points=st.lists(POINTS, min_size=1, max_size=6),
    heading=st.floats(-3.0, 3.0),
    where=st.floats(-5.0, 1.1),
)
def test_pose_at_is_point_at_and_heading_at(
    points: list[tuple[float, float]], heading: float, where: float
) -> None:
    line = Polyline(points, heading_rad=heading)
    asked = [where * line.length, *line.cumulative, 0.0, line.length, line.length + 1.0]
    for s in asked:
        x, y = line.point_at(s)
        assert line.pose_at(s) == Pose(x, y, line.heading_at(s))
