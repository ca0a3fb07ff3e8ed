"""One run's world: the simulated network, its nodes and sessions, and how a step is applied.

Only the public API is used: ``SimulatedNetwork`` and its documented methods, the
``RoleActivator`` of each node, ``groups``, and ``machine.state_counts()`` for the
memory bound. The world keeps the truth the invariants compare the middleware against:
which nodes live, what each publishes, which role names each registered, which sessions
run and when each was stopped.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from objectplaces import NodeConfig, RoleActivator, Session, groups
from objectplaces.core.channel import retransmission_span
from objectplaces.groups import GroupDefinition
from objectplaces.sim import SimulatedNetwork
from tests.soak.probes import Ledger, ProbeInitiator, ProbeParticipant
from tests.soak.workload import (
    HOSTILE,
    Crash,
    Heal,
    InitiatorSends,
    Inject,
    Join,
    Leave,
    Link,
    Move,
    ParticipantSends,
    Partition,
    Placement,
    Rest,
    Restart,
    Scenario,
    Settle,
    Start,
    Step,
    Stop,
    StopAll,
    Wait,
)

__all__ = ["LiveSession", "World", "build_definition", "retransmission_time"]


def build_definition(spec: tuple[object, ...]) -> GroupDefinition:
    """The declarative group definition a ``Start`` step names."""
    match spec:
        case ("overlap",):
            return groups.circles_overlap()
        case ("within", float(d)):
            return groups.within(d)
        case ("near", float(x), float(y), float(d)):
            return groups.near((x, y), d)
        case ("overlap_team", str(team)):
            return groups.circles_overlap() & groups.property_equals("team", team)
        case ("within_or_team", float(d), str(team)):
            return groups.within(d) | groups.property_equals("team", team)
    raise ValueError(f"unknown definition spec {spec!r}")


def retransmission_time(config: NodeConfig, transmissions: int | None = None) -> float:
    """How long a channel takes to transmit one frame ``transmissions`` times (by default
    as often as it ever does: then the channel gives up and counts as broken)."""
    tries = config.max_retransmissions if transmissions is None else transmissions
    return retransmission_span(config.retransmit_timeout, tries)


@dataclass
class LiveSession:
    """A session the workload started, and what became of it."""

    label: int
    node: str
    session: Session
    role: ProbeInitiator
    definition: GroupDefinition
    requested: str
    started_at: float
    stopped_at: float | None = None
    ended: str | None = None  # "crashed" or "left": its initiator node is gone
    ended_at: float | None = None

    @property
    def sid(self) -> str:
        """The session id."""
        return self.session.session_id

    @property
    def running(self) -> bool:
        """Neither stopped nor gone with its node."""
        return self.stopped_at is None and self.ended is None


@dataclass
class World:
    """The network of one scenario and the truth about it."""

    scenario: Scenario
    net: SimulatedNetwork = field(init=False)
    ledger: Ledger = field(init=False)
    sessions: dict[int, LiveSession] = field(default_factory=dict)
    placements: dict[str, Placement] = field(default_factory=dict)
    #: (node, sid, inst) of roles a graceful leave did not deactivate.
    left_behind: list[tuple[str, str, int]] = field(default_factory=list)
    #: When the hostile peer last injected a frame.
    last_injection: float = -math.inf
    #: Exceptions that escaped the middleware, as the runner caught or logged them.
    escaped: list[str] = field(default_factory=list)
    config: NodeConfig = field(init=False)

    def __post_init__(self) -> None:
        s = self.scenario
        self.net = SimulatedNetwork(
            seed=s.seed,
            delay=s.delay,
            jitter=s.jitter,
            loss=s.loss,
            duplicate=s.duplicate,
            reorder=s.reorder,
            cell_size=s.cell_size,
            property_interval=s.property_interval,
            beat_interval=s.beat_interval,
            rest_beat_interval=s.rest_beat_interval,
            failure_timeout=s.failure_timeout,
        )
        self.config = NodeConfig(
            property_interval=s.property_interval,
            beat_interval=s.beat_interval,
            rest_beat_interval=s.rest_beat_interval,
            failure_timeout=s.failure_timeout,
            interest_radius=s.interest_radius,
            cell_size=s.cell_size,
        )
        self.ledger = Ledger(clock=lambda: self.net.now)
        for node, placement in s.initial:
            self._add(node, placement)

    # ------------------------------------------------------------------ truth

    @property
    def now(self) -> float:
        """Virtual time."""
        return self.net.now

    @property
    def live(self) -> list[str]:
        """Live node ids, sorted."""
        return sorted(self.net.nodes)

    def node(self, node: str) -> RoleActivator:
        """The live node ``node``."""
        return self.net.node(node)

    def truth(self, session: LiveSession) -> frozenset[str]:
        """The members ``session`` must converge to: live nodes that match and accept."""
        initiator = self.node(session.node).properties
        found = set()
        for other in self.live:
            if other == session.node or session.requested not in self.ledger.registered[other]:
                continue
            if session.definition(initiator, self.node(other).properties):
                found.add(other)
        return frozenset(found)

    def running_sessions(self) -> list[LiveSession]:
        """Sessions still running, by label."""
        return [s for _, s in sorted(self.sessions.items()) if s.running]

    # ------------------------------------------------------------------ steps

    def apply(self, step: Step) -> None:
        """Apply one workload step (``Settle`` is the runner's: it only waits)."""
        net = self.net
        match step:
            case Move(node, to):
                self._place(self.node(node), to)
            case Start(node, label, spec, requested, faulty):
                initiator = ProbeInitiator(self.ledger, faulty=faulty)
                definition = build_definition(spec)
                started = self.node(node).start_interaction(initiator, definition, requested)
                self.ledger.requested[started.session_id] = requested
                self.sessions[label] = LiveSession(
                    label, node, started, initiator, definition, requested, self.now
                )
            case Stop(label):
                self._stop(self.sessions[label])
            case StopAll():
                for running in self.running_sessions():
                    self._stop(running)
            case InitiatorSends(label, count):
                self._initiator_sends(self.sessions[label], count)
            case ParticipantSends(node, count):
                for key in sorted(k for k in self.ledger.active if k[1] == node):
                    self.node(node).call_later(0.0, self.ledger.active[key].burst(count))
            case Wait(seconds):
                net.run_for(seconds)
            case Crash(node):
                self._gone(node, "crashed")
                net.remove_node(node)
                self.ledger.node_crashed(node)
            case Leave(node):
                self._gone(node, "left")
                net.leave(node)
                for sid, where in sorted(k for k in self.ledger.active if k[1] == node):
                    self.left_behind.append((where, sid, self.ledger.active[(sid, where)].inst))
                self.ledger.node_crashed(node)
            case Restart(node, at) | Join(node, at):
                self._add(node, at)
            case Partition(parts):
                net.partition(*parts)
            case Heal():
                net.heal()
            case Link(a, b, loss, duplicate, reorder):
                net.set_link(a, b, loss=loss, duplicate=duplicate, reorder=reorder)
            case Rest(node, on):
                self.node(node).set_at_rest(on)
            case Inject(target, _, data):
                net.inject(HOSTILE, target, data)
                self.last_injection = self.now
            case Settle():
                pass

    def _add(self, node: str, placement: Placement) -> None:
        activator = self.net.add_node(node, interest_radius=self.scenario.interest_radius)
        names = self.scenario.roles[node]
        self.ledger.registered[node] = names
        for name in sorted(names):
            activator.set_participant_factory(name, self._factory(node, name))
        self._place(activator, placement)

    def _factory(self, node: str, name: str) -> Any:
        ledger = self.ledger

        def make() -> ProbeParticipant:
            return ProbeParticipant(ledger, node, name, faulty=name == "decoy")

        return make

    def _place(self, activator: RoleActivator, placement: Placement) -> None:
        self.placements[activator.node_id] = placement
        activator.update_node_property("position", (placement.x, placement.y))
        activator.update_node_property("hull_length", placement.hull)
        activator.update_node_property("team", placement.team)

    def _initiator_sends(self, session: LiveSession, count: int) -> None:
        role = session.role
        self.node(session.node).call_later(0.0, lambda: role.send_burst(count))

    def _stop(self, session: LiveSession) -> None:
        self.node(session.node).stop_interaction(session.session)
        session.stopped_at = self.now

    def _gone(self, node: str, how: str) -> None:
        for session in self.sessions.values():
            if session.node == node and session.ended is None:
                session.ended = how
                session.ended_at = self.now
                session.role.dead = True
