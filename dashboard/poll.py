"""The generic ``poll`` roles: ask every group member for one of its node's properties.

``PollInitiator`` sends ``{"poll": name}`` to each member as it joins (late joiners too)
and records ``{"property": name, "value": v, "present": bool}`` answers;
``PollResponder`` answers from its own node's current properties. The dashboard
registers the responder on every node under ``RESPONDER_ROLE``, so any node can be
polled through ``POST /api/sessions``.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

from objectplaces.core.ids import InitiatorRef, ParticipantRef
from objectplaces.core.roles import Initiator, Participant
from objectplaces.json_form import json_value

__all__ = ["POLL_ROLE", "RESPONDER_ROLE", "PollInitiator", "PollResponder", "poll_factory"]

POLL_ROLE = "poll"
"""Name of the initiator role in the dashboard's role registry."""

RESPONDER_ROLE = "poll-responder"
"""Name of the participant role the dashboard registers on every node."""


class PollInitiator(Initiator):
    """Asks each member for the property ``name`` and keeps the answers.

    Args:
        name: the property to ask for.
    """

    def __init__(self, name: str) -> None:
        self.name = name
        self.answers: dict[str, Any] = {}
        self.missing: set[str] = set()
        self._asked: set[str] = set()

    def in_group(self, participant: ParticipantRef) -> None:
        """Ask the new member."""
        self._asked.add(participant.node_id)
        self.send(participant, {"poll": self.name})

    def out_group(self, participant: ParticipantRef) -> None:
        """A member left: its answer, if any, stays on record."""
        self._asked.discard(participant.node_id)

    def receive(self, participant: ParticipantRef, message: Any) -> None:
        """Record an answer; anything that is not an answer to our question is ignored."""
        if not isinstance(message, Mapping) or message.get("property") != self.name:
            return
        node = participant.node_id
        if message.get("present", True):
            self.answers[node] = json_value(message.get("value"))
            self.missing.discard(node)
        else:
            self.answers.pop(node, None)
            self.missing.add(node)

    def detail(self) -> dict[str, Any]:
        """What the session detail shows: the property, answers, and who has not answered."""
        answered = set(self.answers) | self.missing
        return {
            "property": self.name,
            "answers": {k: self.answers[k] for k in sorted(self.answers)},
            "missing": sorted(self.missing),
            "pending": sorted(self._asked - answered),
        }


class PollResponder(Participant):
    """Answers polls from its node's own properties.

    Args:
        properties: returns the node's own current properties.
    """

    def __init__(self, properties: Callable[[], Mapping[str, Any]]) -> None:
        self._properties = properties

    def in_group_of(self, initiator: InitiatorRef) -> None:
        """Nothing to do until asked."""

    def receive(self, message: Any) -> None:
        """Answer ``{"poll": name}``; ignore anything else."""
        if not isinstance(message, Mapping) or not isinstance(message.get("poll"), str):
            return
        name = message["poll"]
        props = self._properties()
        if name in props:
            self.send({"property": name, "value": json_value(props[name]), "present": True})
        else:
            self.send({"property": name, "value": None, "present": False})


def poll_factory(params: Mapping[str, Any]) -> PollInitiator:
    """Build a ``PollInitiator`` from request parameters.

    Args:
        params: must hold ``property``, a non-empty string.

    Raises:
        ValueError: ``property`` is missing or not a non-empty string.
    """
    name = params.get("property")
    if not isinstance(name, str) or not name:
        raise ValueError(f"role 'poll' needs params {{'property': <name>}}, got {dict(params)!r}")
    unknown = sorted(set(params) - {"property"})
    if unknown:
        raise ValueError(f"role 'poll' takes only 'property', not {unknown!r}")
    return PollInitiator(name)
