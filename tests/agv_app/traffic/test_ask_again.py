"""A request asked again on its open session (``Requester.ask_again``).

The session keeps its members and channels when the new request's group lies within
the old one's (``group_within``); every voter takes the new message as a new request:
a fresh verdict, fresh records, the one before ended as by ``end``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import pytest

from agv_app.fleet import Fleet, FleetConfig
from agv_app.traffic import LockEntry, RequestEntry, Requester
from agv_app.traffic.collision import group_within, request_group
from objectplaces import ParticipantRef, groups
from objectplaces.sim import SimulatedNetwork
from tests.agv_app.traffic.test_collision import Node, strip
from tuplespace import ANY


def test_group_within_takes_equal_groups_and_inner_boxes_only() -> None:
    outer = request_group(strip(0, 10))
    assert group_within(request_group(strip(0, 10)), outer)
    assert group_within(request_group(strip(0, 5)), outer)  # a shortened request
    assert not group_within(request_group(strip(0, 12)), outer)
    assert not group_within(request_group(strip(-1, 5)), outer)
    assert not group_within(outer, request_group(strip(0, 5)))
    kind = groups.property_equals("kind", "agv")
    assert group_within(kind, groups.property_equals("kind", "agv"))  # broadcast
    assert not group_within(kind, outer)
    other_kind = groups.circle_meets_box((0, 0, 10, 1)) & groups.property_equals("kind", "x")
    assert not group_within(other_kind, groups.circle_meets_box((-5, -5, 20, 5)) & kind)
    assert group_within(
        groups.circle_meets_box((0, 0, 10, 1)) & kind,
        groups.circle_meets_box((-5, -5, 20, 5)) & kind,
    )


def _asking(node: Node, entry: RequestEntry, outcomes: list[str]) -> Requester:
    node.book.add_request(entry)
    definition = request_group(entry.area)
    req = Requester(
        entry,
        safe_time=2.0,
        patience=None,
        group_view=lambda: node.node.view_group(definition),
        on_done=outcomes.append,
        definition=definition,
    )
    node.node.start_interaction(req, definition, "voter")
    return req


def _on(node: Node, fn: Callable[[], Any]) -> None:
    node.node.call_later(0.0, fn)


def _allowed(node: Node) -> list[tuple[Any, ...]]:
    return node.node.space.rd_all(("allowed", ANY, ANY, ANY, ANY))


def test_a_request_asked_again_keeps_its_session_and_is_voted_anew() -> None:
    net = SimulatedNetwork(seed=3, property_interval=1.0)
    a = Node(net, "a", 0.0, 6.0)
    b = Node(net, "b", 8.0, 3.0)
    b.book.set_locks(LockEntry(1, 0.0, strip(4, 6)))  # holds a's first request up
    net.run_for(0.5)
    outcomes: list[str] = []
    req = _asking(a, RequestEntry(1, 5.0, strip(0, 5), (net.now, "a")), outcomes)
    sid = req.session_id
    net.run_for(1.0)
    assert req.votes == {"b": False}
    assert b.voters[0].verdict == "lock"
    assert b.node.space.rdp(("blocking", f"{sid}/1", ANY)) is not None

    shorter = RequestEntry(2, 1.0, strip(0, 1), (net.now, "a"))  # clear of b's lock

    def again() -> None:
        req.withdraw(keep_session=True)
        assert outcomes == ["withdrawn"]
        a.book.add_request(shorter)
        assert req.ask_again(shorter, request_group(shorter.area), announced_at=None)

    _on(a, again)
    net.run_for(0.2)
    # The same session and voter: no new activation, and a fresh verdict of the new one.
    assert req.session_id == sid
    assert len(b.voters) == 1
    assert req.votes == {"b": True}
    assert b.voters[0].verdict == "allow"
    assert [t[1] for t in _allowed(b)] == [f"{sid}/2"]
    # A vote on the first request arriving late is not a vote on this one.
    req.receive(ParticipantRef("b", sid), {"t": "defer", "why": "lock", "k": 1})
    assert req.votes == {"b": True}
    net.run_for(2.0)  # the safe time counts from the new request
    assert outcomes == ["withdrawn", "locked"]
    assert [e.key for e in a.book.locks()] == [2]
    assert _allowed(b) == []  # its end came


def test_a_new_request_on_the_session_ends_the_allow_of_the_one_before() -> None:
    net = SimulatedNetwork(seed=5, property_interval=1.0)
    a = Node(net, "a", 0.0, 6.0)
    b = Node(net, "b", 9.0, 3.0)  # nothing in the way: allows
    net.run_for(0.5)
    outcomes: list[str] = []
    req = _asking(a, RequestEntry(1, 5.0, strip(0, 5), (net.now, "a")), outcomes)
    net.run_for(0.5)
    assert [t[1] for t in _allowed(b)] == [f"{req.session_id}/1"]
    lower = RequestEntry(2, 5.0, strip(0, 5), (net.now + 1.0, "a"))

    def again() -> None:
        req.withdraw(keep_session=True)
        a.book.add_request(lower)
        assert req.ask_again(lower, request_group(lower.area), announced_at=None)

    _on(a, again)
    net.run_for(0.2)
    allowed = _allowed(b)
    assert [t[1] for t in allowed] == [f"{req.session_id}/2"]
    assert allowed[0][3] == lower.priority


@pytest.mark.source_only("replaces Voter._evaluate")
def test_a_voter_deferring_again_rechecks_on_one_timer() -> None:
    net = SimulatedNetwork(seed=3, property_interval=1.0)
    a = Node(net, "a", 0.0, 6.0)
    b = Node(net, "b", 8.0, 3.0)
    b.book.set_locks(LockEntry(1, 0.0, strip(2, 6)))  # holds both requests up
    net.run_for(0.5)
    outcomes: list[str] = []
    req = _asking(a, RequestEntry(1, 5.0, strip(0, 5), (net.now, "a")), outcomes)
    net.run_for(1.0)
    voter = b.voters[0]
    evaluations: list[float] = []
    evaluate = voter._evaluate

    def counted() -> None:
        evaluations.append(net.now)
        evaluate()

    voter._evaluate = counted  # type: ignore[method-assign]
    shorter = RequestEntry(2, 3.0, strip(0, 3), (net.now, "a"))

    def again() -> None:
        req.withdraw(keep_session=True)
        a.book.add_request(shorter)
        req.ask_again(shorter, request_group(shorter.area), announced_at=None)

    _on(a, again)
    net.run_for(2.0)
    assert voter.verdict == "lock"
    # Every 0.25 s (recheck), from one timer: the first request's rechecks stopped.
    assert 6 <= len(evaluations) <= 9, evaluations


def test_a_request_whose_group_reaches_further_opens_a_new_session() -> None:
    net = SimulatedNetwork(seed=3, property_interval=1.0)
    a = Node(net, "a", 0.0, 12.0)
    b = Node(net, "b", 8.0, 3.0)
    net.run_for(0.5)
    outcomes: list[str] = []
    req = _asking(a, RequestEntry(1, 3.0, strip(0, 3), (net.now, "a")), outcomes)
    net.run_for(0.5)
    longer = RequestEntry(2, 10.0, strip(0, 10), (net.now, "a"))
    asked: list[bool] = []

    def again() -> None:
        req.withdraw(keep_session=True)
        asked.append(req.ask_again(longer, request_group(longer.area), announced_at=None))
        req.close()

    _on(a, again)
    net.run_for(0.5)
    assert asked == [False]
    assert a.node.sessions() == []  # closed: its members were let go
    assert _allowed(b) == []  # b allowed the first request, and heard its end
    assert a.book.request() is None


def _sessions_and_safety(reuse: bool) -> tuple[int, int, dict[str, Any]]:
    opened: list[str] = []
    original = Requester.started

    def started(self: Requester) -> None:
        opened.append(self.session_id)
        original(self)

    ask_again = Requester.ask_again
    Requester.started = started  # type: ignore[method-assign]
    if not reuse:
        Requester.ask_again = lambda self, *a, **k: False  # type: ignore[method-assign]
    try:
        # As measured, with 5 m requests: a held-up one is asked again shorter (5, 2.5,
        # 1.25 m), on its open session, more often than with the default 3 m; each
        # station on its own node.
        config = FleetConfig(
            agvs=20, seed=2, load=0.9, advance_m=5.0, station_nodes=True, fail_on_violation=True
        )
        fleet = Fleet(None, config)
        fleet.run(90.0)
    finally:
        Requester.started = original  # type: ignore[method-assign]
        Requester.ask_again = ask_again  # type: ignore[method-assign]
    return len(opened), len(set(opened)), fleet.summary(1.0)


@pytest.mark.source_only("replaces Requester methods")
def test_a_fleet_asks_again_on_open_sessions_as_safely_as_on_new_ones() -> None:
    asked, sessions, kept = _sessions_and_safety(reuse=True)
    plain_asked, plain_sessions, plain = _sessions_and_safety(reuse=False)
    assert plain_asked == plain_sessions  # the plain path: a session per request
    assert sessions < asked  # re-asks on open sessions
    assert sessions < 0.9 * plain_sessions
    for summary in (kept, plain):
        assert summary["collisions"] == summary["lock_overlaps"] == summary["deadlocks"] == 0
    assert kept["locks_granted"] >= 0.9 * plain["locks_granted"]
