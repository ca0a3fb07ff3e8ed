"""Roles that record what the middleware tells them, for scenario tests."""

from __future__ import annotations

from typing import Any

from objectplaces import Initiator, InitiatorRef, Participant, ParticipantRef

Event = tuple[Any, ...]


class RecordingInitiator(Initiator):
    """Logs every callback as (time, what, node[, message])."""

    def __init__(self, greeting: Any = None) -> None:
        self.log: list[Event] = []
        self.greeting = greeting

    def in_group(self, participant: ParticipantRef) -> None:
        self.log.append((self.now(), "in", participant.node_id))
        if self.greeting is not None:
            self.send(participant, self.greeting)

    def out_group(self, participant: ParticipantRef) -> None:
        self.log.append((self.now(), "out", participant.node_id))

    def receive(self, participant: ParticipantRef, message: Any) -> None:
        self.log.append((self.now(), "recv", participant.node_id, message))

    def membership(self) -> list[tuple[str, str]]:
        """The in/out events only, without times."""
        return [(e[1], e[2]) for e in self.log if e[1] in ("in", "out")]

    def received(self) -> list[tuple[str, Any]]:
        """(sender, message) of every message received."""
        return [(e[2], e[3]) for e in self.log if e[1] == "recv"]


class RecordingParticipant(Participant):
    """Logs its callbacks into a shared list; answers with ``reply`` when activated."""

    def __init__(self, log: list[Event], reply: Any = None) -> None:
        self.shared = log
        self.reply = reply
        self.messages: list[Any] = []

    def in_group_of(self, initiator: InitiatorRef) -> None:
        self.shared.append((self.node_id, "in_group_of", initiator.node_id))
        if self.reply is not None:
            self.send(self.reply)

    def out_group_of(self, initiator: InitiatorRef) -> None:
        self.shared.append((self.node_id, "out_group_of", initiator.node_id))

    def receive(self, message: Any) -> None:
        self.messages.append(message)
        self.shared.append((self.node_id, "receive", message))


def place(node: Any, x: float, y: float, radius: float = 1.0) -> None:
    """Publish a node's position and hull length."""
    node.update_node_property("position", (x, y))
    node.update_node_property("hull_length", radius)
