"""Fairness bookkeeping: allowed requests, inherited priorities (docs/traffic.md)."""

from __future__ import annotations

import shapely

from agv_app.geometry import Area
from agv_app.traffic import LockBook
from tuplespace import TupleSpace


class Clock:
    """A settable clock for the tuplespace's leases."""

    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def box(x0: float, x1: float) -> Area:
    return Area(shapely.box(x0, -0.5, x1, 0.5))


def test_an_allowed_request_outranks_ours_for_as_long_as_its_session_lasts() -> None:
    clock = Clock()
    book = LockBook(TupleSpace(clock=clock))
    book.note_allowed("s1", box(0, 10), (50.0, "b"))
    clock.now = 500.0  # far past any fixed keep time: the request may still be pending
    assert book.next_priority(10.0, "a", box(5, 6)) > (50.0, "b")
    assert book.next_priority(10.0, "a", box(20, 30)) == (10.0, "a")  # no overlap


def test_the_requesters_end_lets_our_own_age_count_again() -> None:
    book = LockBook(TupleSpace(clock=Clock()))
    book.note_allowed("s1", box(0, 10), (50.0, "b"))
    book.forget_allowed("s1")
    assert book.next_priority(10.0, "a", box(5, 6)) == (10.0, "a")


def test_after_leaving_the_session_an_allow_is_kept_for_keep_allowed() -> None:
    clock = Clock()
    book = LockBook(TupleSpace(clock=clock))
    book.note_allowed("s1", box(0, 10), (50.0, "b"))
    book.keep_allowed("s1", 30.0)
    clock.now = 29.0
    assert book.next_priority(10.0, "a", box(5, 6)) > (50.0, "b")
    clock.now = 31.0
    assert book.next_priority(10.0, "a", box(5, 6)) == (10.0, "a")


def test_a_lock_owner_inherits_the_oldest_request_it_holds_up() -> None:
    clock = Clock()
    book = LockBook(TupleSpace(clock=clock))
    assert book.inherited() is None
    book.note_blocking("s1", (40.0, "x"), lease=1.5)
    book.note_blocking("s2", (25.0, "y"), lease=1.5)
    book.note_blocking("s2", (25.0, "y"), lease=1.5)  # renewed, not doubled
    assert book.inherited() == 25.0
    clock.now = 2.0  # no longer renewed: the voter stopped deferring
    assert book.inherited() is None
