"""TimerQueue and RoleTimers alone: order, ties, dead entries, bounded size."""

from __future__ import annotations

from objectplaces.core.timers import (
    CheckLiveness,
    ParticipationOwner,
    Republish,
    RoleTimers,
    RunTimer,
    SessionOwner,
    TimerQueue,
)


def test_actions_come_out_by_deadline_and_ties_in_scheduling_order() -> None:
    queue = TimerQueue()
    first, second = Republish(1.0), CheckLiveness(3.0)
    queue.push(2.0, second)
    queue.push(1.0, first)
    queue.push(2.0, first)
    assert queue.next_deadline() == 1.0
    assert queue.pop_due(0.5) is None
    assert [queue.pop_due(2.0) for _ in range(4)] == [first, second, first, None]
    assert queue.next_deadline() is None


def test_the_changed_flag_tells_the_driver_to_reread_the_deadline() -> None:
    queue = TimerQueue()
    assert not queue.changed
    queue.push(1.0, Republish(1.0))
    assert queue.changed
    queue.changed = False
    queue.pop_due(1.0)
    assert queue.changed


def test_role_timers_die_with_their_owner_and_are_skipped() -> None:
    queue = TimerQueue()
    timers = RoleTimers(queue)
    session = SessionOwner("a#1")  # type: ignore[arg-type]
    part = ParticipationOwner("a", 1, 2)
    assert part.session_id == "a#1"
    kept = timers.schedule(0.0, 1.0, lambda: None, part)
    timers.schedule(0.0, 0.5, lambda: None, session)
    timers.schedule(0.0, 0.7, lambda: None, session)
    assert len(timers) == 3
    timers.cancel(session)
    assert len(timers) == 1
    assert queue.next_deadline() == 1.0  # the cancelled ones on top were dropped
    action = queue.pop_due(1.0)
    assert isinstance(action, RunTimer)
    assert action.handle is kept
    assert timers.fire(kept)
    assert not timers.fire(kept)  # runs once
    assert len(timers) == 0


def test_many_cancelled_timers_do_not_pile_up() -> None:
    queue = TimerQueue()
    timers = RoleTimers(queue)
    owner = SessionOwner("a#1")  # type: ignore[arg-type]
    live = timers.schedule(0.0, 1.0, lambda: None, None)
    for i in range(20_000):
        timers.schedule(0.0, 3600.0 + i, lambda: None, owner)  # far ahead, then cancelled
        timers.cancel(owner)
    assert len(queue) < 2_100  # compacted: about twice the live entries, or the floor
    assert queue.next_deadline() == 1.0
    assert not live.cancelled
