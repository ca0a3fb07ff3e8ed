"""Footprints (``NodeConfig.footprint_margin``): a node publishes to the cells its own
circle reaches, so a node with a small circle is heard by few, and the groups stay those
of full dissemination."""

from __future__ import annotations

import os
import random

import pytest

from objectplaces.core.config import NodeConfig
from objectplaces.core.errors import InvalidValueError, LocalProtocolError
from objectplaces.core.node import NodeMachine
from objectplaces.core.spatial import home_cells
from objectplaces.sim import SimulatedNetwork
from objectplaces.transport.routing import CellRouter

from .recording import place, walk_with_sessions

SEED = int(os.environ.get("OP_SEED", "11"))
LARGEST = 12.0  # the largest radius any walker takes
MARGIN = 10.0  # movement between updates, both sides together


def walk(mode: str, seed: int) -> tuple[dict[str, list[tuple[str, str]]], int]:
    """Random walkers in a 200 m square, most with a small circle, some growing and
    shrinking theirs; every fifth one runs a circles_overlap session.

    ``mode``: "full" (hear everyone), "cell" (publish in the own cell, listen over twice
    the largest radius plus the margin) or "footprint". Returns each initiator's group
    events and the number of property frames delivered.
    """
    rng = random.Random(seed)
    net = SimulatedNetwork(seed=seed, delay=0.01, cell_size=10.0)
    names = [f"n{i:02d}" for i in range(60)]
    if mode == "full":
        nodes = {n: net.add_node(n) for n in names}
    elif mode == "cell":
        nodes = {n: net.add_node(n, interest_radius=2 * LARGEST + MARGIN) for n in names}
    else:
        nodes = {
            n: net.add_node(n, interest_radius=LARGEST + MARGIN / 2, footprint_margin=MARGIN / 2)
            for n in names
        }
    events = walk_with_sessions(
        net,
        nodes,
        rng,
        side=200.0,
        radius=lambda: 1.0,
        steps=150,
        regrow=lambda: rng.choice([1.0, 1.0, 4.0, LARGEST]),  # requests and releases
    )
    return events, net.stats().by_kind["property"][0]


def test_footprints_give_the_groups_of_full_dissemination_for_fewer_frames() -> None:
    print(f"OP_SEED={SEED}")
    full_events, _ = walk("full", SEED)
    cell_events, cell_frames = walk("cell", SEED)
    footprint_events, footprint_frames = walk("footprint", SEED)
    assert sum(len(e) for e in full_events.values()) > 10  # the walk exercises groups
    assert cell_events == full_events
    assert footprint_events == full_events
    assert footprint_frames * 4 < cell_frames * 3


def test_a_shrinking_circle_leaves_far_views_and_a_growing_one_arrives_whole() -> None:
    net = SimulatedNetwork(seed=3, delay=0.01, cell_size=5.0)
    far = net.add_node("far", interest_radius=5.0, footprint_margin=2.0)
    mover = net.add_node("mover", interest_radius=5.0, footprint_margin=2.0)
    place(far, 0.0, 0.0)
    mover.update_node_property("colour", "red")
    place(mover, 30.0, 0.0, radius=1.0)
    net.run_for(0.5)
    assert "mover" not in far.view()  # 30 m away, a 1 m circle: not heard
    mover.update_node_property("hull_length", 25.0)
    net.run_for(0.1)
    heard = far.view()["mover"]
    assert heard["hull_length"] == 25.0
    assert heard["colour"] == "red"  # a snapshot: whole, not a delta
    mover.update_node_property("hull_length", 1.0)
    net.run_for(0.1)
    assert "mover" not in far.view()  # told it shrank, not kept as a stale circle


def test_beats_go_to_the_footprint_so_a_silent_node_stays_alive_there() -> None:
    net = SimulatedNetwork(
        seed=4, delay=0.01, cell_size=5.0, beat_interval=0.5, property_interval=None
    )
    listener = net.add_node("listener", interest_radius=5.0, footprint_margin=2.0)
    talker = net.add_node("talker", interest_radius=5.0, footprint_margin=2.0)
    place(listener, 0.0, 0.0)
    place(talker, 20.0, 0.0, radius=15.0)  # its own cell is far; its footprint is not
    net.run_for(10.0)  # many failure timeouts of silence but for beats
    assert "talker" in listener.view()
    assert "departed_failed" not in listener.stats().counters
    assert listener.stats().received["beat"][0] > 10  # kept alive by beats, not updates


def test_home_cells_are_the_own_cell_or_the_footprint_square() -> None:
    assert home_cells((12.0, 3.0), 50.0, None, 10.0) == ((1, 0),)
    assert home_cells((12.0, 2.0), 2.0, 1.0, 10.0) == ((0, -1), (0, 0), (1, -1), (1, 0))
    assert home_cells((12.0, 3.0), "not a number", 0.0, 10.0) == ((1, 0),)


def test_the_router_syncs_a_new_subscriber_of_any_footprint_cell() -> None:
    router = CellRouter()
    router.publish("p", [(0, 0), (0, 1), (5, 5)], home=2)
    assert router.home("p") == ((0, 0), (0, 1))
    assert router.subscribe("s", frozenset({(0, 1)})).publishers == ("p",)
    assert list(router.publish("p", [(0, 0), (0, 1)], home=1)) == ["s"]
    assert router.home("p") == ((0, 0),)
    assert router.subscribe("t", frozenset({(0, 1)})).publishers == ()
    router.forget("p")
    assert router._publishers_in == {}


def test_a_grown_home_splits_its_listeners_into_those_that_heard_it_and_new_ones() -> None:
    router = CellRouter()
    router.subscribe("old", frozenset({(0, 0)}))
    router.subscribe("new", frozenset({(0, 1)}))
    router.subscribe("both", frozenset({(0, 0), (0, 1)}))
    router.subscribe("all", None)
    router.publish("p", [(0, 0)])
    heard, fresh = router.publish_split("p", [(0, 0), (0, 1)], home=2)
    assert list(heard) == ["all", "old", "both"]
    assert list(fresh) == ["new"]
    assert router.home("p") == ((0, 0), (0, 1))


def test_listeners_that_heard_a_node_get_deltas_when_its_home_grows() -> None:
    net = SimulatedNetwork(seed=6, delay=0.01, cell_size=10.0)
    near = net.add_node("near", interest_radius=1.0, footprint_margin=1.0)
    far = net.add_node("far", interest_radius=1.0, footprint_margin=1.0)
    mover = net.add_node("mover", interest_radius=1.0, footprint_margin=1.0)
    place(near, 5.0, 5.0)
    place(far, 25.0, 5.0)
    mover.update_node_property("colour", "red" * 30)  # a snapshot is much larger than a delta
    place(mover, 8.0, 5.0, radius=0.5)
    net.run_for(0.5)
    assert "mover" in near.view()
    assert "mover" not in far.view()

    def received() -> tuple[int, int]:
        near_bytes, far_bytes = (n.stats().received.get("property", (0, 0))[1] for n in (near, far))
        return near_bytes, far_bytes

    near_before, far_before = received()
    mover.update_node_property("hull_length", 15.0)  # the footprint grows into far's cell
    net.run_for(0.1)
    assert far.view()["mover"]["colour"] == "red" * 30  # far got the snapshot
    assert near.view()["mover"]["hull_length"] == 15.0  # near, the delta
    near_after, far_after = received()
    assert 0 < near_after - near_before < far_after - far_before


def test_a_radius_whose_footprint_is_too_large_is_refused_and_nothing_changes() -> None:
    net = SimulatedNetwork(seed=8, cell_size=1.0)
    node = net.add_node("n", interest_radius=5.0, footprint_margin=1.0)
    place(node, 0.0, 0.0, radius=2.0)
    with pytest.raises(InvalidValueError, match="cells"):
        node.update_node_property("hull_length", 1e6)  # a billion cells to publish to
    assert node.properties["hull_length"] == 2.0


@pytest.mark.parametrize("margin", [-1.0, float("nan"), float("inf"), 1e6])
def test_a_bad_footprint_margin_is_refused(margin: float) -> None:
    with pytest.raises(LocalProtocolError, match="footprint_margin"):
        NodeMachine("n", config=NodeConfig(interest_radius=5.0, footprint_margin=margin))


def test_an_interest_square_of_too_many_cells_is_refused() -> None:
    with pytest.raises(LocalProtocolError, match="interest_radius"):
        NodeMachine("n", config=NodeConfig(interest_radius=1e9, cell_size=1.0))
