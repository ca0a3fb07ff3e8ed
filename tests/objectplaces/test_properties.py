"""Properties: each node publishes its own, views keep the newest, loss is repaired."""

from __future__ import annotations

from typing import Any

import pytest

from objectplaces import LocalProtocolError
from objectplaces.sim import SimulatedNetwork


def test_an_update_is_one_message_to_every_node_and_views_follow() -> None:
    net = SimulatedNetwork(seed=1, delay=0.01)
    a, b, c = (net.add_node(n) for n in "abc")
    net.run_for(0.1)
    before = net.stats().by_kind.get("property", (0, 0))[0]
    a.update_node_property("status", "idle")
    net.run_for(0.1)
    assert net.stats().by_kind["property"][0] - before == 2  # one frame to each peer
    assert b.view()["a"] == {"status": "idle"}
    assert c.view()["a"] == {"status": "idle"}
    assert "a" not in a.view()  # the view holds the others
    assert a.properties == {"status": "idle"}


def test_updates_in_the_same_instant_are_coalesced() -> None:
    net = SimulatedNetwork(seed=1)
    a, _ = net.add_node("a"), net.add_node("b")
    net.run_for(0.1)
    before = net.stats().by_kind.get("property", (0, 0))[0]
    a.update_node_property("position", (1.0, 2.0))
    a.update_node_property("hull_length", 3.0)
    a.update_node_property("status", "busy")
    net.run_for(0.1)
    assert net.stats().by_kind["property"][0] - before == 1


def test_observer_sees_local_and_remote_changes_once() -> None:
    net = SimulatedNetwork(seed=2)
    a, b = net.add_node("a"), net.add_node("b")
    seen: list[tuple[str, str, Any]] = []
    handle = a.register_node_property_observer(lambda n, k, v: seen.append((n, k, v)))
    a.update_node_property("status", "idle")
    b.update_node_property("status", "busy")
    net.run_for(0.1)
    b.update_node_property("status", "busy")  # unchanged: observers stay quiet
    net.run_for(0.1)
    assert seen == [("a", "status", "idle"), ("b", "status", "busy")]
    handle.cancel()
    b.update_node_property("status", "idle")
    net.run_for(0.1)
    assert len(seen) == 2


def test_newest_sequence_wins_under_reordering() -> None:
    net = SimulatedNetwork(seed=3, delay=0.01, jitter=0.009, reorder=0.5)
    a, b = net.add_node("a"), net.add_node("b")
    for i in range(50):
        a.update_node_property("counter", i)
        net.run_for(0.001)
    net.run_for(1.0)
    assert b.view()["a"]["counter"] == 49


def test_periodic_republication_repairs_a_lost_update() -> None:
    net = SimulatedNetwork(seed=4, property_interval=1.0)
    a, b = net.add_node("a"), net.add_node("b")
    net.set_link("a", "b", both_ways=False, loss=1.0)
    a.update_node_property("status", "idle")
    net.run_for(0.5)
    assert "a" not in b.view()
    net.set_link("a", "b", both_ways=False, loss=0.0)
    net.run_for(1.0)
    assert b.view()["a"] == {"status": "idle"}


def test_a_lost_update_is_repaired_by_the_next_one_without_republication() -> None:
    net = SimulatedNetwork(seed=4, delay=0.01)  # no republication, no beats
    a, b = net.add_node("a"), net.add_node("b")
    a.update_node_property("hull_length", 1.0)
    a.update_node_property("position", (0.0, 0.0))
    net.run_for(0.5)
    net.set_link("a", "b", both_ways=False, loss=1.0)
    a.update_node_property("hull_length", 9.0)  # lost: a grown circle b must not miss
    net.run_for(0.5)
    net.set_link("a", "b", both_ways=False, loss=0.0)
    a.update_node_property("position", (1.0, 0.0))  # a delta without the hull length
    net.run_for(0.1)
    assert b.view()["a"] == {"hull_length": 9.0, "position": (1.0, 0.0)}
    assert b.stats().counters["publications_missed"] == 1


def test_a_new_node_learns_everyone_at_once() -> None:
    net = SimulatedNetwork(seed=5, delay=0.01)
    a = net.add_node("a")
    a.update_node_property("status", "idle")
    net.run_for(1.0)
    late = net.add_node("late")
    net.run_for(0.05)
    assert late.view()["a"] == {"status": "idle"}


def test_bad_property_use_fails_clearly() -> None:
    net = SimulatedNetwork()
    a = net.add_node("a")
    with pytest.raises(LocalProtocolError, match="non-empty string"):
        a.update_node_property("", 1)
    with pytest.raises(LocalProtocolError, match="not serialisable"):
        a.update_node_property("thing", object())
    with pytest.raises(LocalProtocolError, match="already on the network"):
        net.add_node("a")


def test_failed_node_is_reported_with_its_last_properties() -> None:
    net = SimulatedNetwork(seed=6, property_interval=0.5)
    a, b = net.add_node("a"), net.add_node("b")
    b.update_node_property("position", (3.0, 4.0))
    departed: list[tuple[str, dict[str, Any]]] = []
    a.register_node_departure_observer(lambda n, last: departed.append((n, dict(last))))
    net.run_for(1.0)
    net.remove_node("b")
    net.run_for(0.5 * 3 + 0.6)  # failure timeout (3 intervals) + one liveness check
    assert departed == [("b", {"position": (3.0, 4.0)})]
    assert "b" not in a.view()
