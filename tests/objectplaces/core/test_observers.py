"""Property observers that name the properties they want, against the plain path."""

from __future__ import annotations

from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st

from objectplaces.core.config import NodeConfig
from objectplaces.core.observers import Observers
from objectplaces.core.plumbing import Plumbing
from objectplaces.sim import SimulatedNetwork

NAMES = ("position", "hull_length", "status", "kind")


def queued(observers: Observers, plumbing: Plumbing) -> list[tuple[Any, tuple[Any, ...]]]:
    return [(c.fn, c.args) for c in plumbing.outbox.take_callbacks()]


@given(
    wanted=st.lists(
        st.none() | st.frozensets(st.sampled_from(NAMES), max_size=3), min_size=1, max_size=5
    ),
    changes=st.lists(st.tuples(st.sampled_from("abc"), st.sampled_from(NAMES)), max_size=20),
)
def test_each_observer_hears_its_names_in_registration_order(
    wanted: list[frozenset[str] | None], changes: list[tuple[str, str]]
) -> None:
    plumbing = Plumbing.build("me", NodeConfig())
    observers = Observers(plumbing.outbox)
    callbacks = [lambda *args: None for _ in wanted]
    for callback, names in zip(callbacks, wanted, strict=True):
        observers.add_property(callback, names)
    for i, (node, name) in enumerate(changes):
        observers.property_changed(node, name, i)
    # The plain path: every observer hears every change, and drops what it did not ask for.
    expected = [
        (callback, (node, name, i))
        for i, (node, name) in enumerate(changes)
        for callback, names in zip(callbacks, wanted, strict=True)
        if names is None or name in names
    ]
    assert queued(observers, plumbing) == expected


def test_observers_that_come_and_go_are_heard_from_the_next_change() -> None:
    plumbing = Plumbing.build("me", NodeConfig())
    observers = Observers(plumbing.outbox)

    def hull(*args: Any) -> None: ...

    def every(*args: Any) -> None: ...

    cancel_hull = observers.add_property(hull, ["hull_length"])
    observers.property_changed("a", "hull_length", 1.0)
    cancel_every = observers.add_property(every)
    observers.property_changed("a", "hull_length", 2.0)
    observers.property_changed("a", "status", "idle")
    cancel_hull()
    observers.property_changed("a", "hull_length", 3.0)
    cancel_every()
    observers.property_changed("a", "hull_length", 4.0)
    assert not observers.watching_properties
    assert queued(observers, plumbing) == [
        (hull, ("a", "hull_length", 1.0)),
        (hull, ("a", "hull_length", 2.0)),
        (every, ("a", "hull_length", 2.0)),
        (every, ("a", "status", "idle")),
        (every, ("a", "hull_length", 3.0)),
    ]


def test_a_cancel_takes_back_its_own_registration_of_an_observer_registered_twice() -> None:
    plumbing = Plumbing.build("me", NodeConfig())
    observers = Observers(plumbing.outbox)

    def seen(*args: Any) -> None: ...

    observers.add_property(seen, {"status"})
    cancel_all = observers.add_property(seen)
    cancel_all()
    observers.property_changed("a", "status", "busy")
    observers.property_changed("a", "kind", "agv")
    assert queued(observers, plumbing) == [(seen, ("a", "status", "busy"))]


def test_a_single_name_must_come_in_a_collection() -> None:
    observers = Observers(Plumbing.build("me", NodeConfig()).outbox)
    with pytest.raises(TypeError):
        observers.add_property(lambda *args: None, "hull_length")


def test_the_facade_calls_a_named_observer_only_for_its_names() -> None:
    net = SimulatedNetwork(seed=1)
    a, b = net.add_node("a"), net.add_node("b")
    named: list[tuple[str, str, Any]] = []
    every: list[tuple[str, str, Any]] = []
    b.register_node_property_observer(lambda *args: named.append(args), names={"hull_length"})
    b.register_node_property_observer(lambda *args: every.append(args))
    a.update_node_property("status", "idle")
    a.update_node_property("hull_length", 2.0)
    net.run_for(1.0)
    assert named == [("a", "hull_length", 2.0)]
    assert ("a", "status", "idle") in every
    assert ("a", "hull_length", 2.0) in every
