"""The safe time counts from when the requested area was first announced.

A request asked again for no more than before lies in every circle its AGV published
since it first asked, which the others have had for that long: once every member allowed, it
locks without another safe time (docs/traffic.md, "Asking again").
"""

from __future__ import annotations

from agv_app.geometry import Area
from agv_app.traffic import Requester
from objectplaces.sim import SimulatedNetwork
from tests.agv_app.traffic.test_collision import Node, strip
from tests.agv_app.vehicle.test_next_task import one_agv


def _request(node: Node, announced_at: float | None) -> tuple[Requester, list[str]]:
    outcomes: list[str] = []
    req = node.request(0.0, 5.0, node.node.now(), announced_at=announced_at, outcomes=outcomes)
    return req, outcomes


def _pair() -> tuple[SimulatedNetwork, Node]:
    net = SimulatedNetwork(seed=3, property_interval=1.0)
    a = Node(net, "a", 0.0, 6.0)
    Node(net, "b", 9.0, 3.0)  # in a's group, nothing in the way: it allows
    net.run_for(3.0)
    return net, a


def test_a_request_announced_long_enough_ago_locks_once_all_allowed() -> None:
    net, a = _pair()
    req, outcomes = _request(a, announced_at=net.now - 2.5)
    net.run_for(0.2)
    assert req.votes == {"b": True}
    assert outcomes == ["locked"]


def test_a_fresh_request_still_waits_the_safe_time() -> None:
    net, a = _pair()
    req, outcomes = _request(a, announced_at=None)
    net.run_for(1.9)
    assert req.votes == {"b": True}
    assert outcomes == []
    net.run_for(0.2)
    assert outcomes == ["locked"]


def test_announced_half_a_safe_time_ago_waits_the_rest() -> None:
    net, a = _pair()
    _, outcomes = _request(a, announced_at=net.now - 1.0)
    net.run_for(0.9)
    assert outcomes == []
    net.run_for(0.2)
    assert outcomes == ["locked"]


def test_an_agv_keeps_the_announcement_only_asking_again_for_no_more() -> None:
    _, agv = one_agv()
    small = strip(0.0, 2.5)
    prior: tuple[float, Area, frozenset[tuple[str, int]]] = (3.0, strip(0.0, 5.0), frozenset())
    assert agv.locking.announced_at(10.0, small, frozenset(), prior) == 3.0
    assert agv.locking.announced_at(10.0, strip(0.0, 6.0), frozenset(), prior) == 10.0  # more
    assert agv.locking.announced_at(10.0, small, frozenset({("x", 1)}), prior) == 10.0  # claims
    assert agv.locking.announced_at(10.0, small, frozenset(), None) == 10.0  # a new request
