"""An initiator role that counts what its participants send, for Zenoh session tests."""

from __future__ import annotations

from objectplaces.core.roles import Initiator
from objectplaces.roles import ParticipantRef

__all__ = ["Counter"]


class Counter(Initiator):
    """Counts the messages its participants send."""

    def __init__(self) -> None:
        self.heard = 0

    def receive(self, p: ParticipantRef, message: object) -> None:
        self.heard += 1
