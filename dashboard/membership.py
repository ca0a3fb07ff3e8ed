"""Who joined and left each session, and when: a bounded history kept beside the feed.

``MembershipHistory.observe`` takes the live sessions as the dashboard reads them for
the feed (``DashboardState.sessions``) and compares each one's members with what it saw
the last time. A member that appears is recorded as ``joined``, one that disappears as
``left``, at the simulated time of the look; members present when a session is first
seen count as joined then. Pure: no clock, no I/O; the caller passes ``now``.

Bounded: each session keeps its newest ``max_changes`` changes (``dropped`` counts the
older ones no longer kept), and of the sessions that ended only the ``max_ended`` most
recently ended are remembered. Live sessions are as many as the fleet has.
"""

from __future__ import annotations

from collections import OrderedDict, deque
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Literal

from dashboard.capture import SessionRecord

__all__ = [
    "MAX_CHANGES_PER_SESSION",
    "MAX_ENDED_SESSIONS",
    "MemberChange",
    "MembershipHistory",
    "SessionMembership",
]

MAX_CHANGES_PER_SESSION = 200
"""Newest joins and leaves kept per session."""

MAX_ENDED_SESSIONS = 500
"""Ended sessions whose history is still kept."""

Change = Literal["joined", "left"]


@dataclass(frozen=True, slots=True)
class MemberChange:
    """One member joining or leaving a session at simulated time ``time``."""

    time: float
    node: str
    change: Change


@dataclass(slots=True)
class SessionMembership:
    """One session's members now and the changes that led there."""

    record: SessionRecord
    """The session as last seen (id, initiator, roles, start)."""
    members: frozenset[str]
    changes: deque[MemberChange]
    first_seen: float
    ended_at: float | None = None
    dropped: int = 0
    """Changes no longer kept (the oldest beyond the bound)."""
    joins: int = field(default=0)
    leaves: int = field(default=0)

    @property
    def session_id(self) -> str:
        """The session's id."""
        return self.record.session_id

    def add(self, change: MemberChange) -> None:
        """Record one change, forgetting the oldest when the bound is reached."""
        if self.changes.maxlen is not None and len(self.changes) == self.changes.maxlen:
            self.dropped += 1
        self.changes.append(change)
        if change.change == "joined":
            self.joins += 1
        else:
            self.leaves += 1


class MembershipHistory:
    """The membership history of every live session and of recently ended ones.

    Args:
        max_changes: changes kept per session.
        max_ended: ended sessions remembered.
    """

    def __init__(
        self,
        *,
        max_changes: int = MAX_CHANGES_PER_SESSION,
        max_ended: int = MAX_ENDED_SESSIONS,
    ) -> None:
        self.max_changes = max_changes
        self.max_ended = max_ended
        self._live: dict[str, SessionMembership] = {}
        self._ended: OrderedDict[str, SessionMembership] = OrderedDict()

    def __len__(self) -> int:
        """Sessions remembered, live and ended."""
        return len(self._live) + len(self._ended)

    def observe(self, now: float, sessions: Mapping[str, SessionRecord]) -> None:
        """One look at the live sessions.

        Args:
            now: simulated seconds.
            sessions: every live session by id, with its current members.
        """
        for sid, rec in sessions.items():
            entry = self._live.get(sid)
            if entry is None or entry.record.started_at != rec.started_at:
                if entry is not None:  # the id was reused by a node that restarted
                    self._end(entry, now)
                entry = self._start(now, rec)
            elif entry.members != frozenset(rec.members):
                self._update(now, entry, rec)
        for sid in [sid for sid in self._live if sid not in sessions]:
            self._end(self._live[sid], now)

    def get(self, session_id: str) -> SessionMembership | None:
        """The history of one session, live or recently ended, or None."""
        return self._live.get(session_id) or self._ended.get(session_id)

    def recent(self, limit: int) -> list[SessionMembership]:
        """Up to ``limit`` sessions: the live ones newest first, then the ended ones,
        most recently ended first."""
        live = sorted(
            self._live.values(), key=lambda e: (e.record.started_at, e.session_id), reverse=True
        )
        out = live[:limit]
        for entry in reversed(self._ended.values()):
            if len(out) >= limit:
                break
            out.append(entry)
        return out

    def _start(self, now: float, rec: SessionRecord) -> SessionMembership:
        self._ended.pop(rec.session_id, None)
        entry = SessionMembership(
            record=rec,
            members=frozenset(),
            changes=deque(maxlen=self.max_changes),
            first_seen=now,
        )
        self._live[rec.session_id] = entry
        self._update(now, entry, rec)
        return entry

    def _update(self, now: float, entry: SessionMembership, rec: SessionRecord) -> None:
        members = frozenset(rec.members)
        for node in sorted(members - entry.members):
            entry.add(MemberChange(now, node, "joined"))
        for node in sorted(entry.members - members):
            entry.add(MemberChange(now, node, "left"))
        entry.members = members
        entry.record = rec

    def _end(self, entry: SessionMembership, now: float) -> None:
        del self._live[entry.session_id]
        for node in sorted(entry.members):
            entry.add(MemberChange(now, node, "left"))
        entry.members = frozenset()
        entry.ended_at = now
        self._ended[entry.session_id] = entry
        while len(self._ended) > self.max_ended:
            self._ended.popitem(last=False)
