"""Identifiers and the role references that roles hand each other."""

from __future__ import annotations

from dataclasses import dataclass
from typing import NewType

__all__ = ["InitiatorRef", "NodeId", "ParticipantRef", "SessionId", "session_id_for"]

NodeId = NewType("NodeId", str)
SessionId = NewType("SessionId", str)


def session_id_for(initiator: str, number: int) -> SessionId:
    """Build the network-wide id of session ``number`` started on node ``initiator``."""
    return SessionId(f"{initiator}#{number}")


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
