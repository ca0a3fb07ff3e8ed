"""Hypothesis drives random moves, starts, stops and network trouble; after every step
guarantees 1 (only members' messages, only from their own session), 3 (no in_group for a
node without the role) and 4 (stop leaves nothing behind) must hold."""

from __future__ import annotations

from typing import Any

from hypothesis import settings
from hypothesis import strategies as st
from hypothesis.stateful import RuleBasedStateMachine, invariant, precondition, rule

from objectplaces import Initiator, InitiatorRef, Participant, ParticipantRef, groups
from objectplaces.core.channel import retransmission_span
from objectplaces.core.config import NodeConfig
from objectplaces.sim import SimulatedNetwork

NAMES = ["a", "b", "c", "d", "e"]
WITHOUT_ROLE = "e"


class Checked(Initiator):
    """Asserts guarantee 1 and 3 as events arrive."""

    def __init__(self) -> None:
        self.current: set[str] = set()
        self.violations: list[str] = []

    def in_group(self, participant: ParticipantRef) -> None:
        if participant.node_id == WITHOUT_ROLE:
            self.violations.append(f"in_group for {WITHOUT_ROLE}, which has no such role")
        self.current.add(participant.node_id)
        self.send(participant, "ping")

    def out_group(self, participant: ParticipantRef) -> None:
        self.current.discard(participant.node_id)

    def receive(self, participant: ParticipantRef, message: Any) -> None:
        if participant.node_id not in self.current:
            self.violations.append(f"message from non-member {participant.node_id}")
        if message != ["pong", self.session_id]:
            self.violations.append(f"message of another session: {message!r}")


class Pong(Participant):
    def in_group_of(self, initiator: InitiatorRef) -> None:
        self.send(["pong", initiator.session_id])

    def receive(self, message: Any) -> None:
        self.send(["pong", self.session_id])


class Guarantees(RuleBasedStateMachine):
    def __init__(self) -> None:
        super().__init__()
        self.net = SimulatedNetwork(
            seed=5,
            delay=0.01,
            jitter=0.01,
            loss=0.1,
            duplicate=0.05,
            reorder=0.1,
            property_interval=0.5,
            failure_timeout=30.0,
        )
        self.nodes = {n: self.net.add_node(n) for n in NAMES}
        for name, node in self.nodes.items():
            if name != WITHOUT_ROLE:
                node.set_participant_factory("pong", Pong)
            node.update_node_property("position", (float(NAMES.index(name)), 0.0))
            node.update_node_property("hull_length", 1.0)
        self.live: dict[str, tuple[str, Checked]] = {}
        self.roles: list[Checked] = []

    @rule(name=st.sampled_from(NAMES), x=st.floats(0, 8), y=st.floats(0, 3))
    def move(self, name: str, x: float, y: float) -> None:
        self.nodes[name].update_node_property("position", (x, y))

    @rule(name=st.sampled_from(NAMES))
    def start(self, name: str) -> None:
        role = Checked()
        session = self.nodes[name].start_interaction(role, groups.circles_overlap(), "pong")
        self.live[session.session_id] = (name, role)
        self.roles.append(role)

    @precondition(lambda self: bool(self.live))
    @rule(data=st.data())
    def stop(self, data: st.DataObject) -> None:
        sid = data.draw(st.sampled_from(sorted(self.live)))
        name, _ = self.live.pop(sid)
        self.nodes[name].stop_interaction(sid)

    @rule(seconds=st.sampled_from([0.01, 0.1, 0.5, 2.0]))
    def wait(self, seconds: float) -> None:
        self.net.run_for(seconds)

    @invariant()
    def guarantees_1_and_3(self) -> None:
        for role in self.roles:
            assert role.violations == []

    def teardown(self) -> None:
        for sid, (name, _) in sorted(self.live.items()):
            self.nodes[name].stop_interaction(sid)
        # Retransmissions settle (a channel breaks at the latest), then the tombstones
        # made meanwhile expire (each lives as long as a channel retransmits).
        config = NodeConfig()
        self.net.run_for(
            2 * retransmission_span(config.retransmit_timeout, config.max_retransmissions) + 1.0
        )
        for role in self.roles:
            assert role.violations == []
        for node in self.nodes.values():
            assert node.participations() == []
            assert set(node.machine.state_counts().values()) == {0}, node.machine.state_counts()


Guarantees.TestCase.settings = settings(max_examples=25, stateful_step_count=25, deadline=None)
TestGuarantees = Guarantees.TestCase
