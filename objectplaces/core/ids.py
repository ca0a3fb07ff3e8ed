"""Identifiers and the role references that roles hand each other."""

from __future__ import annotations

from dataclasses import dataclass
from typing import NewType

__all__ = [
    "InitiatorRef",
    "NodeId",
    "ParticipantRef",
    "SessionId",
    "session_id_for",
    "session_number",
]

NodeId = NewType("NodeId", str)
SessionId = NewType("SessionId", str)


def session_id_for(initiator: str, number: int) -> SessionId:
    """Build the network-wide id of session ``number`` started on node ``initiator``."""
    return SessionId(f"{initiator}#{number}")


def session_number(session_id: str, initiator: str) -> int:
    """The number of ``initiator``'s session ``session_id``; -1 when the id is not of a
    session of ``initiator`` (no session has that number)."""
    prefix, _, number = str(session_id).rpartition("#")
    return int(number) if prefix == initiator and number.isdigit() else -1


@dataclass(frozen=True, slots=True)
class ParticipantRef:
    """How an initiator names one of its participants (hashable; equal across rejoins)."""

    node_id: str
    session_id: str

    def __str__(self) -> str:
        return f"{self.node_id}@{self.session_id}"


@dataclass(frozen=True, slots=True)
class InitiatorRef:
    """How a participant names the initiator of its session."""

    node_id: str
    session_id: str

    def __str__(self) -> str:
        return f"{self.node_id}@{self.session_id}"
