"""Tunables of one node, and what introspection shows of its sessions.

Every duration is in seconds of the driver's clock: virtual seconds in the simulation,
loop seconds on the mesh. The machine never reads a clock itself (sans-I/O); these
numbers only ever get added to the ``now`` an input carries.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from objectplaces.core import codec

__all__ = ["NodeConfig", "ParticipationInfo", "SessionInfo"]


@dataclass(frozen=True, slots=True)
class NodeConfig:
    """Tunables of one node; every duration is in seconds.

    Attributes:
        property_interval: republish all properties this often (repairs lost updates, and
            is the heartbeat when no ``beat_interval`` is set); None: never.
        beat_interval: the liveness beat: a node that has published nothing to its scope
            for this long sends a beat, a frame of a few bytes with the number of its
            latest publication (a receiver that is behind asks for a snapshot); a node
            that publishes anyway sends none. With beats, ``property_interval`` can be
            long: liveness no longer needs a full republication (docs/protocol.md §2).
            None: no beats.
        rest_beat_interval: the beat interval of a node at rest (``set_at_rest``: an
            application's node that stands still and has nothing to say, such as a parked
            vehicle), and the longest this node waits for the beats of a resting peer.
            A resting node declares its interval in its beats, first at the usual one
            for a failure timeout, then this often; a receiver counts it failed only
            after ``failure_timeout`` scaled by that interval over ``beat_interval``
            (the interval capped at its own ``rest_beat_interval``: a fleet shares its
            configuration). Needs ``beat_interval``; None: no rest, a node beats every
            ``beat_interval`` always (docs/protocol.md §2).
        failure_timeout: a node not heard for this long leaves every group; None: three
            times the shorter of the beat and property intervals that are on, else no
            failure detection.
        interest_radius: scoped dissemination: hear only nodes within about this
            distance (None: hear every node, the paper's behaviour).
        footprint_margin: with an interest radius, publish to every cell within this
            margin plus the node's own radius (``hull_length``, 0 when unset) of its
            position, instead of to its own cell only (None). A node then hears another
            when its interest square meets the other's footprint square, so a node
            whose circle is small reaches few listeners (docs/protocol.md §5).
        cell_size: side of the grid cells used for dissemination scopes and the index.
        retransmit_timeout: first retransmission of an unacknowledged channel frame.
        max_retransmissions: tries before a channel counts as broken (its peer gone).
        tombstone_ttl: how long a closed channel is remembered to drop its late frames
            (at least as long as a channel retransmits a frame before it breaks).
        probe_interval: an initiator sends ``PROBE`` to each idle member of a session
            this often (a member that no longer knows the channel answers ``LEFT``,
            docs/protocol.md §3); None: never.
        max_frame: largest frame accepted, in bytes.
        send_buffer: role messages a channel holds beyond its window of frames in
            flight; when full, a role's ``send`` returns False (docs/protocol.md §4).
    """

    property_interval: float | None = None
    beat_interval: float | None = None
    rest_beat_interval: float | None = None
    failure_timeout: float | None = None
    interest_radius: float | None = None
    footprint_margin: float | None = None
    cell_size: float = 25.0
    retransmit_timeout: float = 0.2
    max_retransmissions: int = 12
    tombstone_ttl: float = 10.0
    probe_interval: float | None = 10.0
    max_frame: int = codec.DEFAULT_MAX_FRAME
    send_buffer: int = 10_000

    @property
    def effective_failure_timeout(self) -> float | None:
        """The failure timeout in force (explicit, or three liveness intervals)."""
        if self.failure_timeout is not None:
            return self.failure_timeout
        interval = self.liveness_interval
        return None if interval is None else 3 * interval

    @property
    def longest_lease(self) -> float | None:
        """The longest this node lets a peer go unheard before counting it failed: the
        failure timeout, scaled up for a peer at rest (None: no failure detection)."""
        timeout = self.effective_failure_timeout
        if timeout is None:
            return None
        beat, rest = self.beat_interval, self.rest_beat_interval
        if beat is None or rest is None or rest <= beat:
            return timeout
        return timeout * rest / beat

    @property
    def failure_detection_bound(self) -> float | None:
        """The longest from a node's last frame until this node counts it failed: the
        longest lease, plus the third of the timeout between two liveness checks (None:
        no failure detection)."""
        lease, timeout = self.longest_lease, self.effective_failure_timeout
        return None if lease is None or timeout is None else lease + timeout / 3

    @property
    def liveness_interval(self) -> float | None:
        """The longest a live node stays silent: the shorter of the beat and property
        intervals that are on (None: neither is)."""
        intervals = [i for i in (self.beat_interval, self.property_interval) if i is not None]
        return min(intervals) if intervals else None


@dataclass(frozen=True, slots=True)
class SessionInfo:
    """A session this node initiated, as introspection shows it."""

    session_id: str
    initiator: str
    initiator_role: str
    participant_role: str
    members: frozenset[str]
    pending: frozenset[str]
    started_at: float
    definition: Any


@dataclass(frozen=True, slots=True)
class ParticipationInfo:
    """A participant role active on this node."""

    session_id: str
    initiator: str
    participant_role: str
    since: float
