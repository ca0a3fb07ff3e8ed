"""The stall watch counts an AGV stalled past the limit once per stall."""

from __future__ import annotations

from agv_app.fleet import STALL_LIMIT_S, StallWatch


def test_a_stall_counts_once_when_it_passes_the_limit_and_again_after_a_move() -> None:
    watch = StallWatch(limit_s=10.0)
    for t in range(12):
        watch.observe("agv-1", stalled=True, now=float(t))
    assert watch.stalled_for("agv-1", 11.0) == 11.0
    assert watch.deadlocks == 1
    watch.observe("agv-1", stalled=True, now=30.0)
    assert watch.deadlocks == 1
    watch.observe("agv-1", stalled=False, now=31.0)
    assert watch.stalled_for("agv-1", 31.0) == 0.0
    watch.observe("agv-1", stalled=True, now=32.0)
    watch.observe("agv-1", stalled=True, now=42.0)  # exactly the limit: not over it
    assert watch.deadlocks == 1
    watch.observe("agv-1", stalled=True, now=42.5)
    assert watch.deadlocks == 2


def test_the_default_limit_is_the_one_setting() -> None:
    assert StallWatch().limit_s == STALL_LIMIT_S == 180.0
