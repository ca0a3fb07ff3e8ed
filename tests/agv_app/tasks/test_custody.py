"""The custody rule: a held task ends delivered or handed back, never in two hands."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from agv_app.tasks.custody import CustodyMachine, Delivered, HandedBack

GRACE = 30.0


def machine() -> CustodyMachine:
    return CustodyMachine(grace=GRACE)


def test_a_task_named_by_its_vehicle_is_held_until_reported_done() -> None:
    m = machine()
    m.hold("task-1", "agv-1", now=0.0)
    m.named("agv-1", "task-1", now=0.5)
    assert m.next_deadline() is None
    assert m.tick(now=1000.0) == []
    assert m.done("agv-2", "task-1") == []  # another vehicle's report means nothing
    assert m.done("agv-1", "task-1") == [Delivered("task-1", "agv-1")]
    assert m.held() == []


def test_a_vehicle_never_heard_naming_its_task_hands_it_back_after_the_grace() -> None:
    m = machine()
    m.hold("task-1", "agv-1", now=10.0)
    assert m.next_deadline() == 40.0
    assert m.tick(now=39.9) == []
    assert m.tick(now=40.0) == [HandedBack("task-1", "agv-1", "unnamed")]
    assert m.holder("task-1") is None


def test_the_grace_runs_from_when_the_vehicle_stopped_naming_the_task() -> None:
    m = machine()
    m.hold("task-1", "agv-1", now=0.0)
    m.named("agv-1", "task-1", now=1.0)
    m.named("agv-1", None, now=50.0)  # restarted: it forgot the task
    assert m.next_deadline() == 80.0
    m.named("agv-1", None, now=60.0)  # heard again without it: the grace still runs from 50
    assert m.tick(now=79.0) == []
    m.named("agv-1", "task-1", now=79.5)  # it names the task again in time
    assert m.tick(now=200.0) == []
    assert m.holder("task-1") == "agv-1"


def test_dwelling_at_a_drop_with_the_next_task_named_is_within_the_grace() -> None:
    m = machine()
    m.hold("task-1", "agv-1", now=0.0)
    m.named("agv-1", "task-1", now=0.1)
    m.hold("task-2", "agv-1", now=20.0)  # awarded while it dwells at task-1's drop
    m.named("agv-1", "task-2", now=20.1)
    assert m.tick(now=25.0) == []
    assert m.done("agv-1", "task-1") == [Delivered("task-1", "agv-1")]
    assert m.held() == ["task-2"]


def test_a_later_task_reported_done_delivers_the_one_it_was_awarded_behind() -> None:
    m = machine()
    m.hold("task-1", "agv-1", now=0.0)
    m.named("agv-1", "task-1", now=0.1)
    m.hold("task-7", "agv-2", now=0.5)
    m.hold("task-2", "agv-1", now=1.0)  # while it dwells at task-1's drop
    m.named("agv-1", "task-2", now=1.1)
    m.hold("task-3", "agv-1", now=2.0)  # behind task-2
    # The control heard only the last of two reports (it was down for the first).
    assert m.done("agv-1", "task-2") == [
        Delivered("task-1", "agv-1"),
        Delivered("task-2", "agv-1"),
    ]
    assert m.held() == ["task-7", "task-3"]


def test_tasks_restored_in_award_order_are_delivered_up_to_the_one_reported() -> None:
    m = machine()
    for task_id in ("task-1", "task-2", "task-3"):
        m.hold(task_id, "agv-1", now=0.0, restored=True)
    m.named("agv-1", None, now=1.0)
    assert m.done("agv-1", "task-2") == [
        Delivered("task-1", "agv-1"),
        Delivered("task-2", "agv-1"),
    ]
    assert m.held() == ["task-3"]


def test_a_task_not_named_when_the_next_was_awarded_is_not_taken_as_delivered() -> None:
    m = machine()
    m.hold("task-1", "agv-1", now=0.0, restored=True)  # its award never reached the vehicle
    m.named("agv-1", None, now=1.0)
    m.hold("task-2", "agv-1", now=2.0)  # won while free
    m.named("agv-1", "task-2", now=2.1)
    assert m.done("agv-1", "task-2") == [Delivered("task-2", "agv-1")]
    assert m.tick(now=31.0) == [HandedBack("task-1", "agv-1", "unnamed")]


def test_a_vehicle_that_says_returned_hands_the_task_back_at_once() -> None:
    m = machine()
    m.hold("task-1", "agv-1", now=0.0)
    m.named("agv-1", None, now=1.0)
    assert m.returned("agv-2", "task-1") == []
    assert m.returned("agv-1", "task-1") == [HandedBack("task-1", "agv-1", "returned")]
    assert m.returned("agv-1", "task-1") == []


def test_a_stale_returned_does_not_hand_back_a_task_awarded_again_and_named() -> None:
    m = machine()
    m.named("agv-1", "task-1", now=0.0)
    m.hold("task-1", "agv-1", now=0.0)  # won again; its ``returned`` still names it
    assert m.returned("agv-1", "task-1") == []
    assert m.holder("task-1") == "agv-1"
    assert m.next_deadline() is None  # named before the hold: not unnamed


def test_released_tasks_are_forgotten_and_the_grace_must_be_positive() -> None:
    m = machine()
    m.hold("task-1", "agv-1", now=0.0)
    assert m.release("task-1")
    assert not m.release("task-1")
    assert m.tick(now=1e9) == []
    m.named("agv-1", "task-1", now=0.0)
    m.departed("agv-1")
    m.hold("task-1", "agv-1", now=5.0)
    assert m.next_deadline() == 35.0  # what a departed vehicle named is not known
    with pytest.raises(ValueError, match="grace must be a positive number"):
        CustodyMachine(grace=0.0)


_inputs = st.lists(
    st.tuples(
        st.sampled_from(["hold", "named", "done", "returned", "tick", "departed"]),
        st.sampled_from(["agv-1", "agv-2"]),
        st.sampled_from(["task-1", "task-2", "task-3", None]),
        st.floats(0.0, 5.0),
    ),
    max_size=40,
)


@given(_inputs)
def test_a_task_is_held_by_one_vehicle_and_ends_at_most_once_per_hold(inputs) -> None:
    m = machine()
    now = 0.0
    holder: dict[str, str] = {}
    for kind, vehicle, task, step in inputs:
        now += step * 10
        verdicts: list[Delivered | HandedBack] = []
        if kind == "hold" and task is not None and task not in holder:
            m.hold(task, vehicle, now=now)
            holder[task] = vehicle
        elif kind == "named":
            m.named(vehicle, task, now=now)
        elif kind == "done":
            verdicts = list(m.done(vehicle, task))
        elif kind == "returned":
            verdicts = list(m.returned(vehicle, task))
        elif kind == "tick":
            verdicts = list(m.tick(now=now))
        elif kind == "departed":
            m.departed(vehicle)
        for verdict in verdicts:
            assert holder.pop(verdict.task_id) == verdict.vehicle  # once, by its holder
        assert {t: m.holder(t) for t in m.held()} == holder
