"""Scoped dissemination: the same group events as full multicast, for far fewer messages."""

from __future__ import annotations

import os
import random

import pytest

from objectplaces import groups
from objectplaces.sim import SimulatedNetwork

from .recording import RecordingInitiator, RecordingParticipant, place, walk_with_sessions

SEED = int(os.environ.get("OP_SEED", "7"))


def scenario(
    interest_radius: float | None, seed: int
) -> tuple[dict[str, list[tuple[str, str]]], int]:
    """Random walkers in a 240 m square; every fifth one runs a circles_overlap session."""
    rng = random.Random(seed)
    net = SimulatedNetwork(seed=seed, delay=0.01, cell_size=20.0)
    nodes = {
        f"n{i:02d}": net.add_node(f"n{i:02d}", interest_radius=interest_radius) for i in range(60)
    }
    events = walk_with_sessions(
        net, nodes, rng, side=240.0, radius=lambda: rng.uniform(1.0, 5.0), steps=150
    )
    return events, net.stats().by_kind["property"][0]


def test_scoped_dissemination_gives_the_same_group_events_with_far_fewer_messages() -> None:
    print(f"OP_SEED={SEED}")
    full_events, full_messages = scenario(None, SEED)
    scoped_events, scoped_messages = scenario(25.0, SEED)
    assert sum(len(e) for e in full_events.values()) > 10  # the scenario exercises groups
    assert scoped_events == full_events
    assert scoped_messages * 5 < full_messages


def test_a_node_leaving_a_cell_tells_that_cells_subscribers() -> None:
    net = SimulatedNetwork(seed=3, delay=0.01, cell_size=10.0)
    watcher = net.add_node("watcher", interest_radius=15.0)
    walker = net.add_node("walker", interest_radius=15.0)
    place(watcher, 5.0, 5.0)
    place(walker, 12.0, 5.0)
    net.run_for(0.5)
    assert watcher.view()["walker"]["position"] == (12.0, 5.0)
    place(walker, 60.0, 5.0)  # far outside the watcher's cells
    net.run_for(0.5)
    assert "walker" not in watcher.view()  # not a stale position kept forever
    assert watcher.view_group(groups.within(100.0)) == frozenset()


@pytest.mark.parametrize("radius", [None, 30.0])
def test_a_newcomer_learns_its_neighbourhood_within_one_delay(radius: float | None) -> None:
    net = SimulatedNetwork(seed=5, delay=0.01, cell_size=10.0)
    old = net.add_node("old", interest_radius=radius)
    place(old, 3.0, 3.0)
    net.run_for(1.0)
    new = net.add_node("new", interest_radius=radius)
    place(new, 8.0, 3.0)
    net.run_for(0.05)
    assert new.view()["old"]["position"] == (3.0, 3.0)


def final_members(interest_radius: float | None, seed: int) -> dict[str, frozenset[str]]:
    """The random walk of ``scenario`` with a 10 m interest radius, no heartbeat; each
    session's members at the end, from the initiators' own introspection."""
    rng = random.Random(seed)
    net = SimulatedNetwork(seed=seed, delay=0.01, cell_size=5.0)
    names = [f"n{i:02d}" for i in range(60)]
    pos = {n: [rng.uniform(0, 80), rng.uniform(0, 80)] for n in names}
    radius = {n: rng.uniform(1.0, 5.0) for n in names}
    nodes = {n: net.add_node(n, interest_radius=interest_radius) for n in names}
    for n, node in nodes.items():
        node.set_participant_factory("voter", lambda: RecordingParticipant([]))
        place(node, pos[n][0], pos[n][1], radius[n])
    net.run_for(0.5)
    for n in names[::5]:
        nodes[n].start_interaction(RecordingInitiator(), groups.circles_overlap(), "voter")
    for _ in range(100):
        for n in names:
            pos[n][0] = min(80.0, max(0.0, pos[n][0] + rng.uniform(-1.5, 1.5)))
            pos[n][1] = min(80.0, max(0.0, pos[n][1] + rng.uniform(-1.5, 1.5)))
            nodes[n].update_node_property("position", tuple(pos[n]))
        net.run_for(0.2)
    net.run_for(1.0)
    return {n: nodes[n].sessions()[0].members for n in names[::5]}


def test_without_a_heartbeat_scoped_dissemination_still_finds_every_member() -> None:
    print(f"OP_SEED={SEED}")
    full = final_members(None, SEED)
    scoped = final_members(10.0, SEED)
    assert sum(len(m) for m in full.values()) >= 5  # the scenario exercises groups
    assert scoped == full
