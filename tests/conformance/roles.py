"""The roles every conformance scenario plays, on whichever network carries it."""

from __future__ import annotations

from typing import Any, Protocol

from objectplaces import Initiator, Participant
from objectplaces.roles import InitiatorRef, ParticipantRef

RecorderEntry = tuple[str, str, str, Any]
"""(``in``/``out``/``rx``, node id, session id, message or None)."""


class RecorderLog(Protocol):
    """What a scenario reads of a ``Recorder``: its log, its session, its members."""

    log: list[RecorderEntry]

    @property
    def session_id(self) -> str:
        """The id of the recorder's session."""
        ...

    def heard(self, node: str, what: str) -> bool:
        """True once ``node`` sent a message containing ``what``."""
        ...

    def members_now(self) -> set[str]:
        """The ids of the initiator's members now."""
        ...


def heard_in(log: list[RecorderEntry], node: str, what: str) -> bool:
    """True if ``log`` has a message from ``node`` containing ``what``."""
    return any(e[0] == "rx" and e[1] == node and what in str(e[3]) for e in log)


class Recorder(Initiator):
    """Logs every callback with the session it was told about; greets every member."""

    def __init__(self) -> None:
        self.log: list[RecorderEntry] = []

    def in_group(self, p: ParticipantRef) -> None:
        """Log the new member and greet it."""
        self.log.append(("in", p.node_id, p.session_id, None))
        self.send(p, "welcome")

    def out_group(self, p: ParticipantRef) -> None:
        """Log the member that left."""
        self.log.append(("out", p.node_id, p.session_id, None))

    def receive(self, p: ParticipantRef, message: Any) -> None:
        """Log a member's message."""
        self.log.append(("rx", p.node_id, p.session_id, message))

    def members_now(self) -> set[str]:
        """The ids of the current members."""
        return {p.node_id for p in self.members}

    def heard(self, node: str, what: str) -> bool:
        """True once ``node`` sent a message containing ``what``."""
        return heard_in(self.log, node, what)


class Ticker(Participant):
    """Says hello, ticks every 20 ms, echoes; logs its activation."""

    def __init__(self) -> None:
        self.log: list[str] = []
        self.ticks = 0

    def in_group_of(self, initiator: InitiatorRef) -> None:
        """Log the activation, greet the initiator and start ticking."""
        self.log.append(f"in {initiator.session_id}")
        self.send(f"hello from {self.node_id}")
        self.call_later(0.02, self.tick)

    def out_group_of(self, initiator: InitiatorRef) -> None:
        """Log the deactivation."""
        self.log.append(f"out {initiator.session_id}")

    def receive(self, message: Any) -> None:
        """Echo what the initiator said."""
        self.send(f"echo {message}")

    def tick(self) -> None:
        """Send the next tick and schedule the one after."""
        self.ticks += 1
        self.send(f"tick {self.ticks}")
        self.call_later(0.02, self.tick)
