"""An AGV process hears the closed parts of the floor from the observer alone, as the
operator's stop (agv_app/fleet/closed_listener.py). Virtual time."""

from __future__ import annotations

from agv_app.fleet.blocks import FloorBlocks
from agv_app.fleet.closed_listener import CLOSED_PROPERTY, ClosedListener, closed_wire
from agv_app.fleet.view import OBSERVER_ID
from agv_app.layout.blocked import OpenWays
from agv_app.layout.demo import demo_warehouse
from objectplaces.sim import SimulatedNetwork

LANE = "M4550>M3925"


class _Agv:
    ways: OpenWays | None = None


def test_the_closed_parts_come_from_the_observer_alone() -> None:
    layout = demo_warehouse()
    net = SimulatedNetwork(1)
    control, rogue, node = (net.add_node(n) for n in (OBSERVER_ID, "agv-66", "agv-01"))
    published: list[object] = []
    blocks = FloorBlocks(layout, on_change=lambda ways: published.append(closed_wire(ways)))
    agv = _Agv()
    listener = ClosedListener(node, agv, layout)

    rogue.update_node_property(CLOSED_PROPERTY, [[], [LANE]])
    net.run_for(2.0)
    assert agv.ways is None, "a peer's word closes nothing"
    assert listener.refused == 1

    block = blocks.close("segment", LANE)
    assert published == [[[], [LANE]]]
    control.update_node_property(CLOSED_PROPERTY, published[-1])
    net.run_for(2.0)
    assert agv.ways is not None
    assert agv.ways.closed.segments == {LANE}

    for bad in ("nonsense", [[], ["no-such-segment"]], [["no-such-point"], []], [[], [7]]):
        control.update_node_property(CLOSED_PROPERTY, bad)
        net.run_for(2.0)
        assert agv.ways is not None, f"{bad!r} changes nothing"
    assert listener.refused == 5

    # A vehicle that joins later hears what is closed at once.
    control.update_node_property(CLOSED_PROPERTY, published[-1])
    net.run_for(2.0)
    late = _Agv()
    ClosedListener(net.add_node("agv-02"), late, layout)
    net.run_for(2.0)
    assert late.ways is not None

    blocks.reopen(block.id)
    assert published[-1] == [[], []]
    control.update_node_property(CLOSED_PROPERTY, published[-1])
    net.run_for(2.0)
    assert agv.ways is None
