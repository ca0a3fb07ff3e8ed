"""A node may refuse a peer's property values that cannot be true (``set_property_check``)."""

from __future__ import annotations

from typing import Any

from objectplaces.sim import SimulatedNetwork


def no_jumps(_node: str, name: str, value: Any, _now: float) -> bool:
    return name != "position" or abs(value[0]) < 100


def test_a_refused_value_is_not_taken_and_is_counted_against_its_sender() -> None:
    net = SimulatedNetwork(seed=1)
    a, b = net.add_node("a"), net.add_node("b")
    b.set_property_check(no_jumps)
    a.update_node_property("position", (1.0, 2.0))
    net.run_for(1.0)
    assert b.view()["a"]["position"] == (1.0, 2.0)
    a.update_node_property("position", (999.0, 999.0))
    a.update_node_property("hull_length", 2.0)
    net.run_for(1.0)
    assert b.view()["a"]["position"] == (1.0, 2.0)  # the lie is refused ...
    assert b.view()["a"]["hull_length"] == 2.0  # ... the rest of the frame is taken
    stats = b.stats()
    assert stats.dropped_by_peer == {"a": 1}
    assert stats.counters["refused_implausible"] == 1
    a.update_node_property("position", (3.0, 2.0))
    net.run_for(1.0)
    assert b.view()["a"]["position"] == (3.0, 2.0)


def test_a_check_that_raises_lets_the_value_through_and_is_counted() -> None:
    net = SimulatedNetwork(seed=1)
    a, b = net.add_node("a"), net.add_node("b")

    def broken(_node: str, _name: str, _value: Any, _now: float) -> bool:
        raise RuntimeError("bug in the check")

    b.set_property_check(broken)
    a.update_node_property("position", (1.0, 2.0))
    net.run_for(1.0)
    assert b.view()["a"]["position"] == (1.0, 2.0)
    assert b.stats().counters["property_check_errors"] >= 1
    b.set_property_check(None)
    a.update_node_property("position", (4.0, 2.0))
    net.run_for(1.0)
    assert b.view()["a"]["position"] == (4.0, 2.0)
