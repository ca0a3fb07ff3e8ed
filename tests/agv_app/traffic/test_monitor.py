"""The safety monitor flags overlapping hulls and locks, once per lasting overlap."""

from __future__ import annotations

from agv_app.geometry import Pose, hull
from agv_app.traffic.monitor import SafetyMonitor


def box(x: float) -> object:
    return hull(Pose(x, 0.0, 0.0), length=2.0, width=1.0)


def test_touching_is_not_a_collision() -> None:
    m = SafetyMonitor()
    assert m.check(1, 0.1, [("a", box(0.0)), ("b", box(2.0))], []) == []  # type: ignore[list-item]
    assert m.collisions == 0


def test_overlap_is_reported_with_step_agvs_and_shapes_once() -> None:
    m = SafetyMonitor()
    hulls = [("b", box(1.5)), ("a", box(0.0))]
    found = m.check(7, 0.7, hulls, [])  # type: ignore[arg-type]
    assert len(found) == 1
    v = found[0]
    assert (v.step, v.kind, v.agvs) == (7, "collision", ("a", "b"))
    assert v.shapes[0].startswith("POLYGON")
    assert abs(v.area_m2 - 0.5) < 1e-9
    assert m.check(8, 0.8, hulls, []) == []  # type: ignore[arg-type]
    assert m.collisions == 1
    locks = [("a", box(0.0)), ("b", box(0.5))]
    assert m.check(9, 0.9, [], locks)[0].kind == "lock_overlap"  # type: ignore[arg-type]
    assert m.lock_overlaps == 1
    assert "lock_overlap between a and b" in str(m.violations[-1])


def test_one_agvs_own_locks_may_overlap() -> None:
    m = SafetyMonitor()
    assert m.check(1, 0.1, [], [("a", box(0.0)), ("a", box(0.5))]) == []  # type: ignore[list-item]
