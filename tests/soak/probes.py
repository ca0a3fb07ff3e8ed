"""Roles that record what the middleware tells them, as facts for the invariants to judge.

Probes observe and never judge: each callback appends one frozen fact to the run's
``Ledger`` with everything needed to judge it alone (who was a member at that instant,
which message number was due). ``tests/soak/invariants.py`` judges the facts.

Messages between probes are numbered per channel: the initiator numbers what it sends
to a member from 0 each time that member joins (a *generation*), a participant role
numbers what it sends from 0 (each role instance is one activation). A message is
numbered only once ``send`` accepted it, so a refused send (full buffer) leaves no gap.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from objectplaces import Initiator, InitiatorRef, Participant, ParticipantRef

__all__ = [
    "Activated",
    "AppFault",
    "Deactivated",
    "Fact",
    "InGroup",
    "InitiatorHeard",
    "Ledger",
    "OutGroup",
    "ParticipantHeard",
    "ProbeInitiator",
    "ProbeParticipant",
]


class AppFault(Exception):
    """Raised on purpose by faulty application roles: the middleware must survive it."""


@dataclass(frozen=True, slots=True)
class Activated:
    """A participant role instance ``inst`` got ``in_group_of`` on ``node`` in ``sid``."""

    t: float
    node: str
    sid: str
    inst: int
    role: str
    registered: frozenset[str]
    requested: str | None  # None: a session this run did not start (the hostile peer's)
    fresh: bool  # False: the same instance was activated before


@dataclass(frozen=True, slots=True)
class Deactivated:
    """``out_group_of`` on instance ``inst``."""

    t: float
    node: str
    sid: str
    inst: int
    was_active: bool


@dataclass(frozen=True, slots=True)
class InGroup:
    """The initiator of ``sid`` heard ``in_group`` for ``node``."""

    t: float
    sid: str
    node: str
    already_member: bool
    accepted_before: bool  # some role instance on ``node`` was activated in ``sid`` before


@dataclass(frozen=True, slots=True)
class OutGroup:
    """The initiator of ``sid`` heard ``out_group`` for ``node``."""

    t: float
    sid: str
    node: str
    was_member: bool


@dataclass(frozen=True, slots=True)
class InitiatorHeard:
    """The initiator of ``sid`` received a message from ``sender``."""

    t: float
    sid: str
    sender: str
    sender_session: str  # the session id on the participant reference it came with
    notified_member: bool  # in_group seen and no out_group since
    middleware_member: bool  # in the role's ``members`` at that instant
    tag: Any  # the session the message says it was sent in (None: not a probe message)
    inst: Any
    k: Any
    expected_k: int


@dataclass(frozen=True, slots=True)
class ParticipantHeard:
    """Instance ``inst`` on ``node`` received a message from its initiator."""

    t: float
    node: str
    sid: str
    inst: int
    active: bool
    tag: Any
    gen: Any
    expected_gen: Any  # None until the first message
    k: Any
    expected_k: int


Fact = Activated | Deactivated | InGroup | OutGroup | InitiatorHeard | ParticipantHeard


@dataclass
class Ledger:
    """What one run's probes saw, and the little shared state they need to say it."""

    clock: Callable[[], float]
    facts: list[Fact] = field(default_factory=list)
    requested: dict[str, str] = field(default_factory=dict)  # sid -> participant role
    registered: dict[str, frozenset[str]] = field(default_factory=dict)
    active: dict[tuple[str, str], ProbeParticipant] = field(default_factory=dict)
    accepted: set[tuple[str, str]] = field(default_factory=set)  # (sid, node) ever activated
    app_faults: int = 0
    _instances: itertools.count[int] = field(default_factory=lambda: itertools.count(1))

    def new_instance(self) -> int:
        """A fresh instance number."""
        return next(self._instances)

    def node_crashed(self, node: str) -> None:
        """Roles on ``node`` died with it, without a callback."""
        for key in [key for key in self.active if key[1] == node]:
            self.active.pop(key).dead = True


class ProbeInitiator(Initiator):
    """Greets each new member, sends numbered messages on request, records everything.

    Args:
        ledger: the run's ledger.
        faulty: raise ``AppFault`` from every third ``receive`` (after recording).
    """

    def __init__(self, ledger: Ledger, *, faulty: bool = False) -> None:
        self.ledger = ledger
        self.faulty = faulty
        self.current: dict[str, ParticipantRef] = {}
        self.gen: dict[str, int] = {}
        self.sent: dict[str, int] = {}  # node -> accepted sends in its current generation
        self.heard: dict[tuple[str, Any], int] = {}  # (node, inst) -> messages in order
        self.received = 0
        self.dead = False

    def in_group(self, participant: ParticipantRef) -> None:
        node = participant.node_id
        sid = self.session_id
        accepted = (sid, node) in self.ledger.accepted
        self.ledger.facts.append(InGroup(self.now(), sid, node, node in self.current, accepted))
        self.current[node] = participant
        self.gen[node] = self.gen.get(node, 0) + 1
        self.sent[node] = 0
        self._send_to(node, 1)

    def out_group(self, participant: ParticipantRef) -> None:
        node = participant.node_id
        self.ledger.facts.append(OutGroup(self.now(), self.session_id, node, node in self.current))
        self.current.pop(node, None)

    def receive(self, participant: ParticipantRef, message: Any) -> None:
        node = participant.node_id
        probe = isinstance(message, dict) and "inst" in message
        inst = message.get("inst") if probe else None
        key = (node, inst)
        expected = self.heard.get(key, 0)
        k = message.get("k") if probe else None
        self.ledger.facts.append(
            InitiatorHeard(
                self.now(),
                self.session_id,
                node,
                participant.session_id,
                node in self.current,
                participant in self.members,
                message.get("sid") if probe else None,
                inst,
                k,
                expected,
            )
        )
        if probe:
            # Judge each message against the one before it, not against a cascade.
            self.heard[key] = k + 1 if isinstance(k, int) else expected + 1
        self.received += 1
        if self.faulty and self.received % 3 == 0:
            self.ledger.app_faults += 1
            raise AppFault(f"initiator {self.session_id} fails on purpose")

    def send_burst(self, count: int) -> None:
        """Send ``count`` numbered messages to every current member."""
        for node in sorted(self.current):
            self._send_to(node, count)

    def _send_to(self, node: str, count: int) -> None:
        ref = self.current[node]
        for _ in range(count):
            message = {"sid": self.session_id, "gen": self.gen[node], "k": self.sent[node]}
            if not self.send(ref, message):
                return
            self.sent[node] += 1


class ProbeParticipant(Participant):
    """Greets its initiator, sends numbered messages on request, records everything.

    Args:
        ledger: the run's ledger.
        node: the node it was made on.
        name: the participant role name it was registered under.
        faulty: raise ``AppFault`` from every third ``receive`` (after recording).
    """

    def __init__(self, ledger: Ledger, node: str, name: str, *, faulty: bool = False) -> None:
        self.ledger = ledger
        self.node = node
        self.name = name
        self.faulty = faulty
        self.inst = ledger.new_instance()
        self.sid = ""
        self.since = 0.0
        self.active = False
        self.activated = False
        self.dead = False
        self.gen: Any = None
        self.heard = 0  # messages received in order
        self.sent = 0  # accepted sends

    def in_group_of(self, initiator: InitiatorRef) -> None:
        ledger = self.ledger
        sid = initiator.session_id
        ledger.facts.append(
            Activated(
                self.now(),
                self.node,
                sid,
                self.inst,
                self.name,
                ledger.registered.get(self.node, frozenset()),
                ledger.requested.get(sid),
                not self.activated,
            )
        )
        self.sid = sid
        self.since = self.now()
        self.activated = self.active = True
        ledger.active[(sid, self.node)] = self
        ledger.accepted.add((sid, self.node))
        self.send_burst(1)

    def out_group_of(self, initiator: InitiatorRef) -> None:
        sid = initiator.session_id
        self.ledger.facts.append(Deactivated(self.now(), self.node, sid, self.inst, self.active))
        self.active = False
        if self.ledger.active.get((sid, self.node)) is self:
            del self.ledger.active[(sid, self.node)]

    def receive(self, message: Any) -> None:
        probe = isinstance(message, dict) and "k" in message
        k = message.get("k") if probe else None
        gen = message.get("gen") if probe else None
        self.ledger.facts.append(
            ParticipantHeard(
                self.now(),
                self.node,
                self.sid,
                self.inst,
                self.active,
                message.get("sid") if probe else None,
                gen,
                self.gen,
                k,
                self.heard,
            )
        )
        if probe:
            if self.gen is None:
                self.gen = gen
            self.heard = k + 1 if isinstance(k, int) else self.heard + 1
        if self.faulty and self.heard % 3 == 0:
            self.ledger.app_faults += 1
            raise AppFault(f"participant {self.inst} on {self.node} fails on purpose")

    def burst(self, count: int) -> Callable[[], None]:
        """``send_burst(count)``, to run later."""
        return lambda: self.send_burst(count)

    def send_burst(self, count: int) -> None:
        """Send ``count`` numbered messages to the initiator."""
        for _ in range(count):
            if not self.send({"sid": self.sid, "inst": self.inst, "k": self.sent}):
                return
            self.sent += 1
