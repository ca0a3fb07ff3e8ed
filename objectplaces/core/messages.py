"""The messages nodes exchange, as plain values (immutable by convention).

Two families travel between nodes:

* property dissemination (unreliable, newest wins): ``PropertyUpdate``, ``Beat``,
  ``PropertyRequest`` and ``Leave``;
* session channels (reliable, FIFO per initiator-participant pair): ``ChannelData``
  carrying a ``FrameKind`` and ``ChannelAck``.

A channel is named by the initiator's session number and an *epoch*: the n-th time that
participant node was activated in that session. A node that leaves a group and comes back
gets a fresh epoch, so nothing of its earlier channel can leak into the new one.

The frequent ones (updates, beats, channel frames and acks) are plain slotted classes with
a frozen value's equality and hash, not frozen dataclasses: every delivered frame makes
one, and a frozen dataclass sets each field through ``object.__setattr__`` (three times
the cost). Nobody assigns to their fields.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from enum import IntEnum
from typing import Any, Final, TypeAlias

__all__ = [
    "KIND_NAMES",
    "Beat",
    "ChannelAck",
    "ChannelData",
    "FrameKind",
    "Leave",
    "Message",
    "PropertyRequest",
    "PropertyUpdate",
    "Unusable",
    "kind_of",
]


class FrameKind(IntEnum):
    """What a reliable channel frame carries."""

    ACTIVATE = 0  # initiator -> participant: payload [participant_role, initiator_role]
    ACTIVATED = 1  # participant -> initiator
    DECLINED = 2  # participant -> initiator: no factory for the role here
    DEACTIVATE = 3  # initiator -> participant: session stopped or node left the group
    ROLE = 4  # either way: an application message between roles
    LEFT = 5  # participant -> initiator, out of band: the role ended on the participant's
    #           side without the initiator's word (it took the initiator for failed)
    PROBE = 6  # initiator -> participant: nothing for the role; a member that no longer
    #            knows the channel answers LEFT (an idle session's check, §3)


@dataclass(slots=True, unsafe_hash=True)
class PropertyUpdate:
    """New values of some of the sender's properties, numbered by the sender.

    Attributes:
        seq: the sender's publication counter; per property, the highest seq wins.
        values: property name -> value (only the names that changed, or all of them
            when republished).
        full: a snapshot: ``values`` holds every property the sender has. A receiver
            that holds a node from deltas only asks it for a snapshot
            (``PropertyRequest``), so it never computes with half a node.
    """

    seq: int
    values: Mapping[str, Any]
    full: bool = False


@dataclass(slots=True, unsafe_hash=True)
class Beat:
    """ "I am alive, and my latest publication was number ``seq``": sent instead of a
    property update by a node that has published nothing for a beat interval
    (docs/protocol.md §2). A receiver holding an older number of the sender missed a
    publication and asks for a snapshot (``PropertyRequest``).

    Attributes:
        seq: the sequence number of the sender's latest publication to its scope.
        rest: set by a node at rest while it announces its rest: its beat interval
            now, in seconds; a receiver waits that much longer for it before counting
            it failed (``NodeConfig.rest_beat_interval``), until the node publishes or
            says 0.0: its rest ended, the usual interval again. None: no news (a
            receiver keeps what it granted).
    """

    seq: int
    rest: float | None = None


@dataclass(frozen=True, slots=True)
class PropertyRequest:
    """ "Send me all your properties": the answer is a snapshot, to the asker alone."""


@dataclass(frozen=True, slots=True)
class Unusable:
    """A well-formed property frame the node must not apply: a ``position`` or
    ``hull_length`` it cannot compute with (NaN, a string ...).

    Decoders return this instead of raising: the frame is refused as a whole, yet a
    transport has no reason to close the link, and the machine drops it and counts it
    against its sender.

    Attributes:
        reason: what was wrong, for the log.
    """

    reason: str


@dataclass(frozen=True, slots=True)
class Leave:
    """The sender leaves the network on purpose (a crash sends nothing)."""


@dataclass(slots=True, unsafe_hash=True)
class ChannelData:
    """One numbered frame of a session channel.

    Attributes:
        to_participant: direction: True from initiator to participant.
        session: the session number on the initiator's node.
        epoch: the participant's activation count in this session (1, 2, ...).
        seq: position in this direction's stream, from 0.
        kind: what the frame carries.
        payload: the frame's content (see ``FrameKind``).
    """

    to_participant: bool
    session: int
    epoch: int
    seq: int
    kind: FrameKind
    payload: Any = None


@dataclass(slots=True, unsafe_hash=True)
class ChannelAck:
    """Cumulative acknowledgement: every frame up to ``ack`` arrived in order.

    ``of_participant_stream`` tells which stream is acknowledged: False when a participant
    acks the initiator's frames, True when the initiator acks the participant's.
    """

    of_participant_stream: bool
    session: int
    epoch: int
    ack: int


Message: TypeAlias = (
    PropertyUpdate | Beat | PropertyRequest | Leave | ChannelData | ChannelAck | Unusable
)


KIND_NAMES: Final[Mapping[type, str]] = {
    PropertyUpdate: "property",
    Beat: "beat",
    ChannelData: "channel",
    ChannelAck: "ack",
    Leave: "leave",
    Unusable: "property",
    PropertyRequest: "property",
}
"""Message type -> its family's name in statistics (a dict: it is read for every frame)."""


def kind_of(message: Message) -> str:
    """Name a message's family for statistics ("property", "beat", "channel", "ack" ...)."""
    return KIND_NAMES[type(message)]
