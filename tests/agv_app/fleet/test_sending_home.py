"""Sending a vehicle home over the observer's property: the control's word alone, each
request acted on once and answered (the AGV processes: tests/agv_app/fleet/test_mesh_service.py)."""

from __future__ import annotations

from agv_app.fleet.sending_home import (
    SEND_HOME_PROPERTY,
    SENT_HOME_PROPERTY,
    SendHomeListener,
    SendHomeOrders,
    asked_in,
)
from agv_app.fleet.view import OBSERVER_ID
from objectplaces.sim import SimulatedNetwork


def test_orders_number_each_request_and_drop_it_once_answered() -> None:
    orders = SendHomeOrders()
    assert orders.ask("agv-02") == 1
    assert orders.ask("agv-01") == 2
    assert orders.wire() == [["agv-01", 2], ["agv-02", 1]]
    assert asked_in(orders.wire(), "agv-02") == 1
    assert asked_in(orders.wire(), "agv-03") is None
    assert asked_in("home!", "agv-01") is None
    assert asked_in([["agv-01", True]], "agv-01") is None
    assert not orders.answered("agv-02", 7), "an answer to another request"
    assert orders.answered("agv-02", 1)
    assert orders.wire() == [["agv-01", 2]]


def test_a_vehicle_goes_home_once_per_request_and_only_at_the_control_s_word() -> None:
    net = SimulatedNetwork(1)
    control, rogue, node = (net.add_node(n) for n in (OBSERVER_ID, "agv-66", "agv-01"))
    went: list[int] = []
    listener = SendHomeListener(node, lambda: went.append(1))
    rogue.update_node_property(SEND_HOME_PROPERTY, [["agv-01", 1]])
    net.run_for(2.0)
    assert went == [], "a peer's word sends nobody home"
    assert listener.refused == 1
    control.update_node_property(SEND_HOME_PROPERTY, [["agv-01", 1], ["agv-02", 1]])
    net.run_for(2.0)
    assert went == [1]
    assert control.view()["agv-01"][SENT_HOME_PROPERTY] == 1, "it answered"
    control.update_node_property(SEND_HOME_PROPERTY, [["agv-01", 1], ["agv-02", 2]])
    net.run_for(2.0)
    assert went == [1], "the same request is acted on once"
    control.update_node_property(SEND_HOME_PROPERTY, [["agv-01", 3]])
    net.run_for(2.0)
    assert went == [1, 1]


def test_a_vehicle_that_cannot_go_declines_and_still_answers() -> None:
    net = SimulatedNetwork(1)
    control, node = (net.add_node(n) for n in (OBSERVER_ID, "agv-01"))

    def loaded() -> None:
        raise ValueError("agv-01 is loaded")

    listener = SendHomeListener(node, loaded)
    control.update_node_property(SEND_HOME_PROPERTY, [["agv-01", 4]])
    net.run_for(2.0)
    assert listener.declined == ["agv-01 is loaded"]
    assert control.view()["agv-01"][SENT_HOME_PROPERTY] == 4
