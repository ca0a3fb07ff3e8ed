"""``dashboard.membership``: joins and leaves per session, bounded."""

from __future__ import annotations

from dashboard.capture import SessionRecord
from dashboard.membership import MembershipHistory


def rec(sid: str, *members: str, started_at: float = 0.0) -> SessionRecord:
    return SessionRecord(sid, sid.split("#")[0], "requester", "voter", members, started_at)


def changes(history: MembershipHistory, sid: str) -> list[tuple[float, str, str]]:
    entry = history.get(sid)
    assert entry is not None
    return [(c.time, c.node, c.change) for c in entry.changes]


def test_joins_and_leaves_are_recorded_when_seen() -> None:
    history = MembershipHistory()
    history.observe(1.0, {"a#1": rec("a#1", "b")})
    history.observe(2.0, {"a#1": rec("a#1", "b", "c")})
    history.observe(3.0, {"a#1": rec("a#1", "c")})
    assert changes(history, "a#1") == [
        (1.0, "b", "joined"),
        (2.0, "c", "joined"),
        (3.0, "b", "left"),
    ]
    entry = history.get("a#1")
    assert entry is not None
    assert entry.members == {"c"}
    assert (entry.joins, entry.leaves, entry.ended_at) == (2, 1, None)


def test_an_ended_session_keeps_its_history_and_its_members_leave() -> None:
    history = MembershipHistory()
    history.observe(1.0, {"a#1": rec("a#1", "b")})
    history.observe(4.0, {})
    entry = history.get("a#1")
    assert entry is not None
    assert entry.ended_at == 4.0
    assert entry.members == frozenset()
    assert changes(history, "a#1")[-1] == (4.0, "b", "left")
    assert [e.session_id for e in history.recent(10)] == ["a#1"]


def test_live_sessions_come_first_newest_first_then_the_recently_ended() -> None:
    history = MembershipHistory()
    history.observe(1.0, {"a#1": rec("a#1"), "a#2": rec("a#2", started_at=0.5)})
    history.observe(2.0, {"a#2": rec("a#2", started_at=0.5), "a#3": rec("a#3", started_at=1.5)})
    assert [e.session_id for e in history.recent(10)] == ["a#3", "a#2", "a#1"]
    assert [e.session_id for e in history.recent(2)] == ["a#3", "a#2"]


def test_changes_and_ended_sessions_are_bounded() -> None:
    history = MembershipHistory(max_changes=3, max_ended=2)
    for t in range(6):
        history.observe(float(t), {"a#1": rec("a#1", f"n{t}")})
    entry = history.get("a#1")
    assert entry is not None
    assert len(entry.changes) == 3
    assert entry.dropped == 11 - 3  # 6 joins and 5 leaves
    for k in range(2, 6):
        history.observe(10.0 + k, {f"a#{k}": rec(f"a#{k}")})
    history.observe(20.0, {})
    assert len(history) == 2
    assert history.get("a#1") is None
    assert history.get("a#5") is not None


def test_a_reused_id_starts_a_fresh_history() -> None:
    history = MembershipHistory()
    history.observe(1.0, {"a#1": rec("a#1", "b", started_at=0.0)})
    history.observe(9.0, {"a#1": rec("a#1", "c", started_at=8.0)})
    assert changes(history, "a#1") == [(9.0, "c", "joined")]
