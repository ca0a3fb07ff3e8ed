"""Declarative comparisons, and declarative definitions combined with plain callables."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import pytest

from objectplaces import Initiator, LocalProtocolError, Participant, groups
from objectplaces.sim import SimulatedNetwork


def test_comparisons_decide_on_the_candidates_property_only() -> None:
    above, below = groups.property_above("battery", 50), groups.property_below("battery", 50)
    among = groups.property_in("status", ["idle", "charging"])
    me = {"battery": 0, "status": "busy"}  # the initiator's own values play no part
    assert above(me, {"battery": 50.5})
    assert not above(me, {"battery": 50})
    assert below(me, {"battery": 49})
    assert not below(me, {"battery": 50})
    for no_number in ({}, {"battery": "full"}, {"battery": True}, {"battery": None}):
        assert not above(me, no_number)
        assert not below(me, no_number)
    assert among(me, {"status": "idle"})
    assert among(me, {"status": "charging"})
    assert not among(me, {"status": "busy"})
    assert not among(me, {})


def test_comparisons_refuse_what_they_cannot_compare() -> None:
    with pytest.raises(LocalProtocolError, match="finite number"):
        groups.property_above("battery", float("nan"))
    with pytest.raises(LocalProtocolError, match="finite number"):
        groups.property_below("battery", "50")  # type: ignore[arg-type]
    with pytest.raises(LocalProtocolError, match="a list of values"):
        groups.property_in("status", "idle")
    with pytest.raises(LocalProtocolError, match="non-empty string"):
        groups.property_above("", 1)


def battery_ok(initiator: Mapping[str, Any], participant: Mapping[str, Any]) -> bool:
    return bool(participant.get("battery", 0) > 50)


def test_a_callable_combines_with_a_declarative_definition_either_way() -> None:
    for defn in (groups.within(40) & battery_ok, battery_ok & groups.within(40)):
        assert isinstance(defn, groups.AllOf)
        assert defn({"position": (0, 0)}, {"position": (30, 0), "battery": 60})
        assert not defn({"position": (0, 0)}, {"position": (30, 0), "battery": 40})
        assert not defn({"position": (0, 0)}, {"position": (50, 0), "battery": 60})
        # The spatial part's reach stays: the callable is tried only near the initiator.
        reach = defn.reach({"position": (0, 0)}, lambda name: 0.0)
        assert reach is not None
        assert reach.radius == 40
    either = groups.within(1) | battery_ok
    assert either({"position": (0, 0)}, {"position": (90, 0), "battery": 60})
    assert either.reach({"position": (0, 0)}, lambda name: 0.0) is None  # any node may


def test_a_definition_holding_a_callable_says_it_has_no_json_form() -> None:
    defn = groups.within(40) & battery_ok
    with pytest.raises(LocalProtocolError, match="no JSON form"):
        defn.to_json()
    assert defn == groups.within(40) & battery_ok  # still comparable and hashable
    assert hash(defn) == hash(groups.within(40) & battery_ok)
    assert defn != groups.within(40) & (lambda i, p: True)


def test_combining_with_what_is_no_definition_says_what_to_write() -> None:
    with pytest.raises(TypeError, match=r"& combines group definitions: .* got 3"):
        groups.within(40) & 3  # type: ignore[operator]
    with pytest.raises(TypeError, match=r"\| combines group definitions"):
        groups.within(40) | "near"  # type: ignore[operator]


class Counter(Participant):
    pass


def place(net: SimulatedNetwork, node_id: str, x: float, **props: object) -> None:
    node = net.node(node_id)
    node.update_node_property("position", (x, 0.0))
    for name, value in props.items():
        node.update_node_property(name, value)
    node.set_participant_factory("counter", Counter)


def three_nodes() -> SimulatedNetwork:
    net = SimulatedNetwork(seed=3)
    for node_id in ("a", "b", "c"):
        net.add_node(node_id)
    place(net, "a", 0.0)
    place(net, "b", 10.0, battery=80)
    place(net, "c", 20.0, battery=20)
    net.run_for(0.5)
    return net


def test_a_session_over_a_combined_definition_runs_and_introspects() -> None:
    net = three_nodes()
    a = net.node("a")
    role = Initiator()
    session = a.start_interaction(role, groups.within(40) & battery_ok, "counter")
    net.run_for(1.0)
    assert [m.node_id for m in role.members] == ["b"]
    a.update_node_property("position", (1.0, 0.0))  # re-resolves through the callable
    (info,) = a.sessions()
    assert "Predicate" in info.definition  # its repr: there is no JSON form
    a.stop_interaction(session)
    net.run_for(1.0)
    assert a.sessions() == []


class BrokenReach(groups.Within):
    def reach(self, initiator: object, max_of: object) -> groups.Reach | None:
        raise AttributeError("a bug in a subclass")


def test_a_failed_start_raises_our_error_and_leaves_nothing_behind() -> None:
    net = three_nodes()
    a, role = net.node("a"), Initiator()
    with pytest.raises(LocalProtocolError, match="cannot resolve a group") as caught:
        a.start_interaction(role, BrokenReach(40), "counter")
    assert isinstance(caught.value.__cause__, AttributeError)
    net.run_for(1.0)
    assert a.sessions() == []
    assert all(net.node(n).participations() == [] for n in ("b", "c"))
    a.update_node_property("position", (2.0, 0.0))  # the node carries on
    session = a.start_interaction(role, groups.within(40), "counter")  # the role is free
    assert session.session_id == "a#1"  # no number was taken by the failed start
    with pytest.raises(LocalProtocolError, match="cannot resolve a group"):
        a.view_group(BrokenReach(40))
    with pytest.raises(LocalProtocolError, match="must be callable"):
        a.start_interaction(Initiator(), "within 40", "counter")  # type: ignore[arg-type]
