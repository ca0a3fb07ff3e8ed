"""What a node machine shows of itself: sessions, roles, counters and table sizes.

Read-only questions about the machine's parts, kept apart from the router
(node.py), which decides; ``NodeMachine`` inherits them. Tests check memory bounds
and cleanup on ``footprint`` and ``state_counts``; the dashboard and the benches read
the rest.
"""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType

from objectplaces.core.config import ParticipationInfo, SessionInfo
from objectplaces.core.intake import Intake
from objectplaces.core.outbox import Outbox
from objectplaces.core.own import OwnProperties
from objectplaces.core.participations import ParticipationTable
from objectplaces.core.roles import Initiator
from objectplaces.core.sessions import SessionTable
from objectplaces.core.timers import RoleTimers, TimerQueue
from objectplaces.core.view import PropertyView

__all__ = ["Introspection"]


class Introspection:
    """Read-only answers about a node machine's parts (the machine sets them)."""

    _sessions: SessionTable
    _participations: ParticipationTable
    _intake: Intake
    _outbox: Outbox
    _view: PropertyView
    _own: OwnProperties
    _timers: TimerQueue
    _role_timers: RoleTimers

    def sessions(self) -> list[SessionInfo]:
        """Live sessions started on this node, oldest first."""
        return self._sessions.infos()

    def session_role(self, sid: str) -> Initiator | None:
        """The initiator role of a live session of this node, if any."""
        return self._sessions.role_of(sid)

    def participations(self) -> list[ParticipationInfo]:
        """Participant roles active on this node."""
        return self._participations.infos()

    @property
    def dropped_by_peer(self) -> Mapping[str, int]:
        """Frames refused per peer (malformed or with unusable values; read-only)."""
        return self._intake.dropped_by_peer

    @property
    def counters(self) -> Mapping[str, int]:
        """What this node dropped, broke, retransmitted ... and how often (read-only)."""
        return MappingProxyType(self._outbox.counters)

    def footprint(self) -> dict[str, int]:
        """Sizes of everything the node keeps, sessions or not: memory bounds are tested
        on this (``state_counts`` are the per-session structures alone)."""
        parts = (self._view, self._intake, self._own)
        counts = {k: v for part in parts for k, v in part.footprint().items()}
        return {**counts, **self.state_counts(), "timers": len(self._timers)}

    def state_counts(self) -> dict[str, int]:
        """Sizes of every per-session structure, to check that nothing is left behind."""
        counts = {**self._sessions.counts(), **self._participations.counts()}
        return {**counts, "role_timers": len(self._role_timers)}
