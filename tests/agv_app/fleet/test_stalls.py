"""The stall watch counts an AGV stalled past the limit once per stall."""

from __future__ import annotations

from agv_app.fleet import LONG_WAIT_S, STALL_LIMIT_S, StallWatch


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


def test_waits_over_a_minute_count_once_each_and_the_longest_is_kept() -> None:
    watch = StallWatch()
    assert LONG_WAIT_S == 60.0
    for t in range(0, 62):
        watch.observe("agv-1", stalled=True, now=float(t))
        watch.observe("agv-2", stalled=t < 30, now=float(t))
    assert watch.long_waits == 1
    assert watch.max_wait == 61.0
    watch.observe("agv-1", stalled=True, now=90.0)
    assert (watch.long_waits, watch.max_wait) == (1, 90.0)
    watch.observe("agv-1", stalled=False, now=91.0)
    watch.observe("agv-1", stalled=True, now=92.0)
    watch.observe("agv-1", stalled=True, now=152.5)
    assert (watch.long_waits, watch.max_wait, watch.deadlocks) == (2, 90.0, 0)
