"""What the initiator keeps of one session it started (docs/protocol.md §3).

A session is formed and kept up to date entirely by its initiator's middleware; the
participants only answer. Its state is four tables, each there for a guarantee:

* ``members``: nodes sent ``ACTIVATE``, each with its own channel and epoch. A member is
  *pending* until it answers ``ACTIVATED``; only then does the role hear ``in_group``,
  and only joined members' messages ever reach the role (guarantee 1).
* ``declined``: nodes that answered ``DECLINED`` (no factory for the role there). They
  are not asked again while they keep matching, and the role never hears of them
  (guarantee 3). A node that stops matching leaves this set, so it is asked afresh if
  it matches again later (it may have registered the role since).
* ``closing``: channels of removed members whose ``DEACTIVATE`` is not yet
  acknowledged. They keep retransmitting until the peer acks or the channel breaks; a
  frame arriving on one is acked (so the peer stops retransmitting) but never
  delivered: that is how "late messages of a removed participant are dropped"
  (guarantee 1) is enforced without any timing assumption.
* ``epochs``: how many times each node was activated in this session. Each activation
  gets a new channel named by (session, epoch), so a node that leaves and rejoins can
  never have an old frame taken for a new one (§4). Kept for the session's life: a
  participant may still hold a tombstone for an old epoch, and a reused epoch would
  be taken for that closed channel.

A stopped session is forgotten once it has neither members nor closing channels
(guarantee 4: nothing left behind).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field

from objectplaces.core.channel import Channel
from objectplaces.core.config import SessionInfo
from objectplaces.core.groups import DefinitionLike, describe
from objectplaces.core.ids import SessionId
from objectplaces.core.roles import Initiator

__all__ = ["MemberState", "SessionState", "session_counts"]


@dataclass(slots=True)
class MemberState:
    """One node asked to play in a session."""

    node: str
    epoch: int
    channel: Channel
    joined: bool = False  # False while pending: ACTIVATE sent, no answer yet


@dataclass(slots=True)
class SessionState:
    """One session this node initiated."""

    number: int
    sid: SessionId
    role: Initiator
    definition: DefinitionLike
    participant_role: str
    started_at: float
    members: dict[str, MemberState] = field(default_factory=dict)
    closing: dict[tuple[str, int], Channel] = field(default_factory=dict)
    declined: set[str] = field(default_factory=set)
    epochs: dict[str, int] = field(default_factory=dict)
    stopped: bool = False
    probed_at: float = float("-inf")  # when its idle members were last probed

    @property
    def done(self) -> bool:
        """Stopped, and nothing of it left to wait for."""
        return self.stopped and not self.members and not self.closing

    def to_probe(self, now: float, every: float) -> list[MemberState]:
        """The joined members whose channels are idle, once every ``every`` seconds of
        the session's life (an empty list in between). Nothing sent means nothing
        to break: a member whose LEFT was lost would stay a member for good."""
        if now < max(self.started_at, self.probed_at) + every:
            return []
        self.probed_at = now
        return [m for m in self.members.values() if m.joined and m.channel.idle]

    def close(self, node: str, epoch: int | None = None) -> None:
        """Stop waiting for ``node``'s closing channel of ``epoch`` (None: all of them)."""
        for key in [k for k in self.closing if k[0] == node and epoch in (None, k[1])]:
            self.closing.pop(key).closed = True

    def info(self, node_id: str) -> SessionInfo:
        """The session as introspection shows it."""
        members = self.members.items()
        return SessionInfo(
            self.sid,
            node_id,
            type(self.role).__name__,
            self.participant_role,
            frozenset(n for n, m in members if m.joined),
            frozenset(n for n, m in members if not m.joined),
            self.started_at,
            describe(self.definition),
        )


def session_counts(sessions: Iterable[SessionState]) -> dict[str, int]:
    """Sizes of the per-session structures of ``sessions`` (all 0 once none is left)."""
    counts = {"sessions": 0, "members": 0, "closing_channels": 0}
    for session in sessions:
        counts["sessions"] += 1
        counts["members"] += len(session.members)
        counts["closing_channels"] += len(session.closing)
    return counts
