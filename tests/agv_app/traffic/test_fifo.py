"""First come, first served at every conflict (``agv_app.traffic.fifo``): ages, the
voter's rank, allows taken back, and a request asked again when an older one held it up.
"""

from __future__ import annotations

import math

from agv_app.traffic import LockBook, LockEntry, RequestEntry, Requester, decide_vote
from agv_app.traffic.collision import request_group
from agv_app.traffic.fifo import (
    INHERITED_AHEAD_S,
    allows_to_revoke,
    priority_at,
    ranks_higher,
    wait_age,
)
from objectplaces.sim import SimulatedNetwork
from tests.agv_app.traffic.test_collision import Node, strip
from tuplespace import ANY


def _book(name: str = "v") -> LockBook:
    return LockBook(SimulatedNetwork(seed=1).add_node(name).space)


def test_a_wait_takes_the_age_of_an_older_request_its_locks_hold_up() -> None:
    book = _book()
    assert wait_age(10.0, book) == 10.0
    book.note_blocking("s#1/1", (12.0, "x"), lease=5.0)  # younger: nothing to inherit
    assert wait_age(10.0, book) == 10.0
    book.note_blocking("s#2/1", (4.0, "y"), lease=5.0)
    assert wait_age(10.0, book) == 4.0 - INHERITED_AHEAD_S


def test_a_request_ranks_below_what_its_node_allowed_until_the_allow_ends() -> None:
    book = _book()
    book.note_allowed("s#1/3", strip(0, 4), (6.0, "x"))
    assert priority_at(2.0, "v", strip(2, 5), book) == (6.0 + 1e-6, "v")
    assert priority_at(2.0, "v", strip(10, 12), book) == (2.0, "v")  # elsewhere
    pending = RequestEntry(1, 5.0, strip(2, 5), (6.0 + 1e-6, "v"), age=2.0)
    assert not ranks_higher(pending, 2.0, "v", book)
    book.forget_allowed("s#1/3")
    assert ranks_higher(pending, 2.0, "v", book)


def test_allows_of_younger_requests_over_our_floor_are_taken_back_but_not_our_blockers() -> None:
    book = _book()
    book.note_allowed("a#1/1", strip(0, 4), (1.0, "a"))  # older than our wait: it stays
    book.note_allowed("b#1/1", strip(0, 4), (6.0, "b"))
    book.note_allowed("c#1/1", strip(0, 4), (7.0, "c"))  # c's lock holds us up
    book.note_allowed("d#1/1", strip(20, 24), (8.0, "d"))  # not our floor
    assert allows_to_revoke(2.0, "v", strip(2, 5), book, keep={"c"}) == ["b#1/1"]


def test_an_allow_the_other_way_through_a_run_counts_as_a_conflict_without_overlap() -> None:
    # Two stretches of one two-way run that do not overlap, driven head-on: granted
    # both, the two AGVs meet inside the run (halls seed 125 of the floor runner).
    book = _book()
    west, east = frozenset({("door", -1)}), frozenset({("door", 1)})
    book.note_allowed("s#1/3", strip(6, 10), (6.0, "x"), west)
    assert priority_at(2.0, "v", strip(0, 4), book, east) == (6.0 + 1e-6, "v")
    assert priority_at(2.0, "v", strip(0, 4), book, west) == (2.0, "v")  # following
    assert priority_at(2.0, "v", strip(0, 4), book) == (2.0, "v")  # outside the run
    assert allows_to_revoke(2.0, "v", strip(0, 4), book, claims=east) == ["s#1/3"]
    assert allows_to_revoke(2.0, "v", strip(0, 4), book, claims=west) == []


def test_a_voter_defers_a_request_younger_than_its_own_wait_whatever_its_priority() -> None:
    book = _book()
    # Our request ranks at 9.0 (below one we allowed) but serves a wait of age 2.0.
    book.add_request(RequestEntry(2, 0.0, strip(2, 6), (9.0, "v"), age=2.0))
    own = book.request()
    assert own is not None
    assert (own.priority, own.age) == ((9.0, "v"), 2.0)

    def around(x0: float, x1: float) -> tuple[float, float, float]:
        return (x0 + x1) / 2, 0.0, math.hypot(x1 - x0, 1.0)

    assert decide_vote(strip(4, 8), (5.0, "r"), book, around(4, 8)) == "priority"
    assert decide_vote(strip(4, 8), (1.0, "r"), book, around(4, 8)) == "allow"
    book.withdraw(2)
    assert book.space.rd_all(("age", ANY, ANY)) == []


def test_an_allow_taken_back_counts_no_more_and_its_voter_then_defers() -> None:
    net = SimulatedNetwork(seed=5, property_interval=1.0)
    a = Node(net, "a", 0.0, 7.0)
    b = Node(net, "b", 10.0, 7.0)
    net.run_for(0.5)
    outcomes: list[str] = []
    rb = b.request(4.0, 10.0, 1.0, outcomes=outcomes)
    net.run_for(0.2)
    record = f"{rb.session_id}/1"
    assert rb.votes == {"a": True}
    assert [t[1] for t in a.book.space.rd_all(("allowed", ANY, ANY, ANY, ANY))] == [record]
    # a now waits for the same floor with an older wait (it inherited one), its
    # priority still below b's request, which it allowed: it takes the allow back.
    a.book.add_request(RequestEntry(1, 6.0, strip(0, 6), (1.0 + 1e-6, "a"), age=0.2))
    a.book.revoke(record, lease=2.0)
    net.run_for(0.2)
    assert rb.votes == {"a": False}
    assert a.book.allowed() == []
    assert a.voters[0].verdict == "priority"
    net.run_for(3.0)  # past the safe time: without a's allow it cannot lock
    assert (rb.done, outcomes) == ("", [])
    a.book.withdraw(1)  # a got its floor elsewhere: b's request goes on
    net.run_for(1.0)
    assert outcomes == ["locked"]


def test_a_voter_of_a_new_participation_drops_the_allows_kept_from_the_last() -> None:
    net = SimulatedNetwork(seed=6, property_interval=1.0)
    a = Node(net, "a", 0.0, 7.0)
    b = Node(net, "b", 10.0, 7.0)
    c = Node(net, "c", 8.0, 2.0)
    c.book.set_locks(LockEntry(1, 0.0, strip(7.5, 8.5)))  # keeps b's request pending
    net.run_for(0.5)
    rb = b.request(4.0, 10.0, 1.0)
    net.run_for(0.2)
    assert rb.votes == {"a": True, "c": False}
    a.move(60.0, 1.0)  # a leaves b's group: its allow is kept a while (keep_allowed)
    net.run_for(1.5)
    assert [t[1] for t in a.book.space.rd_all(("allowed", ANY, ANY, ANY, ANY))] == [
        f"{rb.session_id}/1"
    ]
    a.book.add_request(RequestEntry(1, 6.0, strip(0, 6), (0.2, "a")))
    a.move(0.0, 7.0)  # and comes back: b asks it afresh, and it now defers
    net.run_for(1.5)
    assert rb.votes == {"a": False, "c": False}
    assert a.voters[-1].verdict == "priority"
    assert a.book.allowed() == []


def test_a_request_held_up_by_an_older_one_is_asked_again_instead_of_withdrawn() -> None:
    net = SimulatedNetwork(seed=4, property_interval=1.0)
    a = Node(net, "a", 0.0, 7.0)
    b = Node(net, "b", 10.0, 7.0)
    net.run_for(0.5)
    b.book.add_request(RequestEntry(7, 0.0, strip(4, 10), (0.1, "b")))  # older, pending
    entry = RequestEntry(1, 6.0, strip(0, 6), (0.5, "a"))
    a.book.add_request(entry)
    outwaited: list[float] = []
    definition = request_group(entry.area)
    req = Requester(
        entry,
        safe_time=2.0,
        patience=None,
        queue_patience=3.0,
        group_view=lambda: a.node.view_group(definition),
        on_done=lambda outcome: outwaited.append(-1.0),
        on_outwaited=lambda: outwaited.append(net.now),
    )
    a.node.start_interaction(req, definition, "voter")
    net.run_for(4.0)
    assert req.done == ""  # still pending: no moment without a request
    assert len(outwaited) == 1
    assert 3.5 <= outwaited[0] <= 3.6
