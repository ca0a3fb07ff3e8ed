"""Roles that record what the middleware tells them, for scenario tests."""

from __future__ import annotations

import random
from collections.abc import Callable, Mapping
from typing import Any

from objectplaces import (
    Initiator,
    InitiatorRef,
    Participant,
    ParticipantRef,
    RoleActivator,
    groups,
)
from objectplaces.sim import SimulatedNetwork

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


def walk_with_sessions(
    net: SimulatedNetwork,
    nodes: Mapping[str, RoleActivator],
    rng: random.Random,
    *,
    side: float,
    radius: Callable[[], float],
    steps: int,
    regrow: Callable[[], float] | None = None,
) -> dict[str, list[tuple[str, str]]]:
    """Random walkers in a square of ``side`` m, 1.5 m a step at most; every fifth one
    runs a ``circles_overlap`` session. ``radius`` draws each walker's hull length;
    ``regrow``, when given, draws a new one for about one walker in twenty per step.

    Returns:
        Each initiator's in/out events, in order.
    """
    log: list[Event] = []
    names = sorted(nodes)
    pos = {n: [rng.uniform(0, side), rng.uniform(0, side)] for n in names}
    for n in names:
        nodes[n].set_participant_factory("voter", lambda: RecordingParticipant(log))
        place(nodes[n], pos[n][0], pos[n][1], radius())
    net.run_for(0.5)
    roles = {n: RecordingInitiator() for n in names[::5]}
    for n, role in roles.items():
        nodes[n].start_interaction(role, groups.circles_overlap(), "voter")
    for _ in range(steps):
        for n in names:
            pos[n][0] = min(side, max(0.0, pos[n][0] + rng.uniform(-1.5, 1.5)))
            pos[n][1] = min(side, max(0.0, pos[n][1] + rng.uniform(-1.5, 1.5)))
            nodes[n].update_node_property("position", tuple(pos[n]))
            if regrow is not None and rng.random() < 0.05:
                nodes[n].update_node_property("hull_length", regrow())
        net.run_for(0.2)
    return {n: role.membership() for n, role in roles.items()}
