"""Memory stays bounded in the core over long runs (issue 10, item 5).

A steady workload (moving nodes, sessions started and stopped, roles that set timers far
ahead and are deactivated, a crash and a restart, a peer that sends garbage under ever
new names) must leave each node's footprint as large after three rounds as after one.
"""

from __future__ import annotations

import math
import random
from collections.abc import Callable
from typing import Any

import msgpack
import pytest

from objectplaces import Initiator, Participant, ParticipantRef, groups
from objectplaces.core import codec
from objectplaces.core.intake import MAX_PEERS
from objectplaces.core.messages import ChannelAck, ChannelData, FrameKind, PropertyRequest
from objectplaces.sim import SimulatedNetwork

from .recording import place

NAMES = [f"n{i}" for i in range(8)]


class Patient(Initiator):
    """Sets a timer an hour ahead for each member; it dies with the session."""

    def in_group(self, participant: ParticipantRef) -> None:
        self.call_later(3600.0, lambda: None)
        self.send(participant, "hello")


class Echo(Participant):
    def in_group_of(self, initiator: Any) -> None:
        self.call_later(3600.0, lambda: None)

    def receive(self, message: Any) -> None:
        self.send(message)


def round_of_work(net: SimulatedNetwork, rng: random.Random, fakes: list[int]) -> None:
    """One minute of virtual time: moves, sessions, a crash, garbage from strangers."""
    nodes = net.nodes
    for step in range(60):
        for name, node in nodes.items():
            node.update_node_property("position", (rng.uniform(0, 30), rng.uniform(0, 30)))
            if step % 20 == 0:
                session = node.start_interaction(Patient(), groups.circles_overlap(), "echo")
                net.call_later(10.0, stopper(net, name, session.session_id))
        for _ in range(20):  # strangers, each under a name never seen before
            fakes[0] += 1
            stranger, target = f"stranger-{fakes[0]}", rng.choice(NAMES)
            garbage = [
                b"\x93garbage",
                msgpack.packb([1, 1, {"position": [math.nan, 0]}]),
                codec.encode(ChannelData(True, rng.randrange(99), 1, 3, FrameKind.ROLE, 1)),
                codec.encode(ChannelAck(False, rng.randrange(99), 1, 7)),
                codec.encode(PropertyRequest()),
            ]
            net.inject(stranger, target, rng.choice(garbage))
        net.run_for(1.0)
    net.remove_node("n7")  # a crash; it comes back as a new run
    net.run_for(2.0)
    node = net.add_node("n7")
    node.set_participant_factory("echo", Echo)
    place(node, 15, 15, 3.0)


def stopper(net: SimulatedNetwork, name: str, sid: str) -> Callable[[], None]:
    """Stops session ``sid`` of ``name``, unless a crash took it first."""

    def stop() -> None:
        node = net.nodes.get(name)
        if node is not None and sid in {s.session_id for s in node.sessions()}:
            node.stop_interaction(sid)

    return stop


def footprints(net: SimulatedNetwork) -> dict[str, dict[str, int]]:
    return {name: node.machine.footprint() for name, node in net.nodes.items()}


@pytest.mark.parametrize("heartbeat", [0.5, None], ids=["heartbeat", "no-heartbeat"])
def test_a_long_steady_run_keeps_every_nodes_footprint_flat(heartbeat: float | None) -> None:
    rng = random.Random(3)
    net = SimulatedNetwork(seed=3, delay=0.01, loss=0.05, property_interval=heartbeat)
    for name in NAMES:
        node = net.add_node(name, interest_radius=None if name < "n4" else 12.0)
        node.set_participant_factory("echo", Echo)
        place(node, rng.uniform(0, 30), rng.uniform(0, 30), 3.0)
    fakes = [0]
    round_of_work(net, rng, fakes)
    first = footprints(net)
    for _ in range(2):
        round_of_work(net, rng, fakes)
    last = footprints(net)
    assert fakes[0] > 2 * MAX_PEERS // len(NAMES)  # strangers enough to fill the tables
    for name, sizes in last.items():
        assert sizes["view"] <= len(NAMES) - 1, sizes
        assert sizes["heard"] <= len(NAMES) - 1, sizes  # no stranger made it in
        assert sizes["dropped_peers"] <= MAX_PEERS
        assert sizes["logged_peers"] <= MAX_PEERS
        # Cancelled timers an hour ahead stay queued until the queue compacts itself,
        # which it does whenever it doubles: bounded by its floor plus what is live.
        assert sizes["timers"] <= 1024 + 2 * (sizes["role_timers"] + 40)
        for key, size in sizes.items():
            if key in ("dropped_peers", "logged_peers", "timers"):
                continue  # these fill up to their bounds, checked above
            assert size <= max(2 * first[name][key], 40), (name, key, first[name], sizes)
