"""Failed AGVs relayed by every vehicle that saw them fail: no control process needed."""

from __future__ import annotations

from agv_app.protocol import AGV_KIND
from agv_app.traffic.lockbook import LockBook
from agv_app.traffic.stale_relay import FAILED_AGVS, StaleListener, StaleRelay
from objectplaces.sim import SimulatedNetwork


def _agv(net: SimulatedNetwork, node_id: str, x: float) -> None:
    node = net.add_node(node_id)
    node.update_node_property("kind", AGV_KIND)
    node.update_node_property("position", (x, 0.0))
    node.update_node_property("hull_length", 2.0)


def test_a_failure_stays_recorded_while_any_relay_lists_it() -> None:
    net = SimulatedNetwork(seed=1, property_interval=0.5)
    _agv(net, "dead", 0.0)
    relays = [net.add_node(name) for name in ("r1", "r2")]
    for relay in relays:
        StaleRelay(relay)
    listener = net.add_node("me")
    book = LockBook(listener.space)
    StaleListener(listener, lambda: book)
    net.run_for(1.0)
    net.remove_node("dead")  # it crashed: silent, without a goodbye
    net.run_for(5.0)  # the failure timeout: both relays saw it fail
    assert [r.node_id for r in book.stale()] == ["dead"]
    # One relay hears it again (it was only late there): the other still lists it.
    relays[0].update_node_property(FAILED_AGVS, [])
    net.run_for(1.0)
    assert [r.node_id for r in book.stale()] == ["dead"]
    relays[1].update_node_property(FAILED_AGVS, [])
    net.run_for(1.0)
    assert book.stale() == []
