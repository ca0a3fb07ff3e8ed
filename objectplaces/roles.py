"""Role base classes and the references roles use to name each other."""

from __future__ import annotations

from objectplaces.core.events import TimerHandle
from objectplaces.core.ids import InitiatorRef, ParticipantRef
from objectplaces.core.members import MemberSet
from objectplaces.core.roles import Initiator, OutReason, Participant

__all__ = [
    "Initiator",
    "InitiatorRef",
    "MemberSet",
    "OutReason",
    "Participant",
    "ParticipantRef",
    "TimerHandle",
]
