"""PropertyView alone: newest wins per property, the index, the scope, read-only views."""

from __future__ import annotations

from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st

from objectplaces import groups
from objectplaces.core.config import NodeConfig
from objectplaces.core.messages import PropertyUpdate
from objectplaces.core.observers import Observers
from objectplaces.core.plumbing import Plumbing
from objectplaces.core.view import PropertyView


def view(plumbing: Plumbing | None = None) -> PropertyView:
    plumbing = plumbing or Plumbing.build("me", NodeConfig(cell_size=10.0))
    return PropertyView(plumbing, observers=Observers(plumbing.outbox))


def test_newest_wins_per_property_not_per_frame_and_observers_hear_each_change() -> None:
    plumbing = Plumbing.build("me", NodeConfig(cell_size=10.0))
    outbox = plumbing.outbox
    observers = Observers(outbox)
    seen: list[tuple[str, str, Any]] = []
    observers.add_property(lambda *args: seen.append(args))
    v = PropertyView(plumbing, observers=observers)
    assert v.apply("b", PropertyUpdate(5, {"status": "busy"}), now=1.0)
    # An older republication carries every property: only the ones not newer count.
    assert v.apply("b", PropertyUpdate(4, {"status": "idle", "kind": "agv"}), now=2.0)
    assert v.mapping == {"b": {"status": "busy", "kind": "agv"}}
    assert not v.apply("b", PropertyUpdate(6, {"status": "busy"}), now=3.0)  # unchanged
    for callback in outbox.take_callbacks():
        callback.fn(*callback.args)
    assert seen == [("b", "status", "busy"), ("b", "kind", "agv")]


@given(
    updates=st.lists(
        st.tuples(st.integers(0, 20), st.sampled_from("xy"), st.integers(0, 3)), max_size=30
    )
)
def test_any_arrival_order_ends_with_each_propertys_highest_sequence(
    updates: list[tuple[int, str, int]],
) -> None:
    v = view()
    for seq, name, value in updates:
        v.apply("b", PropertyUpdate(seq, {name: value}), now=0.0)
    expected: dict[str, tuple[int, int]] = {}
    for seq, name, value in updates:
        if name not in expected or seq > expected[name][0]:
            expected[name] = (seq, value)
    assert dict(v.props_of("b") or {}) == {n: sv[1] for n, sv in expected.items()}


def test_handed_out_mappings_are_read_only_and_live() -> None:
    v = view()
    v.apply("b", PropertyUpdate(1, {"status": "idle"}), now=0.0)
    mapping, props = v.mapping, v.props_of("b")
    assert props is not None
    with pytest.raises(TypeError):
        mapping["c"] = {}  # type: ignore[index]
    with pytest.raises(TypeError):
        props["status"] = "x"  # type: ignore[index]
    v.apply("b", PropertyUpdate(2, {"status": "busy"}), now=0.0)
    assert props["status"] == "busy"


def test_candidates_come_from_the_index_for_declarative_definitions() -> None:
    v = view()
    for i, x in enumerate([1.0, 4.0, 30.0, 300.0]):
        v.apply(f"n{i}", PropertyUpdate(1, {"position": (x, 0.0), "hull_length": 1.0}), now=0.0)
    own = {"position": (0.0, 0.0), "hull_length": 1.0}
    near = set(v.candidates(groups.within(5.0), own))
    assert {"n0", "n1"} <= near
    assert "n3" not in near  # 300 m away: its cell is never visited
    assert v.group(groups.within(5.0), own) == frozenset({"n0", "n1"})
    opaque = set(v.candidates(lambda mine, theirs: True, own))
    assert opaque == {"n0", "n1", "n2", "n3"}  # an opaque callable sees everyone
    v.apply("n1", PropertyUpdate(2, {"position": (200.0, 0.0)}), now=0.0)  # the index follows
    assert v.group(groups.within(5.0), own) == frozenset({"n0"})
    v.forget("n0")
    assert v.group(groups.within(5.0), own) == frozenset()


def test_a_radius_grows_the_reach_of_circles_overlap() -> None:
    v = view()
    v.apply("big", PropertyUpdate(1, {"position": (40.0, 0.0), "hull_length": 1.0}), now=0.0)
    own = {"position": (0.0, 0.0), "hull_length": 1.0}
    assert v.group(groups.circles_overlap(), own) == frozenset()
    v.apply("big", PropertyUpdate(2, {"hull_length": 39.0}), now=0.0)  # the running max rises
    assert v.group(groups.circles_overlap(), own) == frozenset({"big"})


def test_a_raising_definition_counts_as_no_match_and_is_counted() -> None:
    plumbing = Plumbing.build("me", NodeConfig(cell_size=10.0))
    outbox = plumbing.outbox
    v = view(plumbing)
    v.apply("b", PropertyUpdate(1, {"status": "idle"}), now=0.0)

    def broken(mine: Any, theirs: Any) -> bool:
        raise RuntimeError("boom")

    assert v.group(broken, {}) == frozenset()
    assert outbox.counters == {"definition_errors": 1}


def test_the_scope_forgets_nodes_outside_it_but_keeps_nodes_without_a_position() -> None:
    v = view()
    v.apply("near", PropertyUpdate(1, {"position": (5.0, 5.0)}), now=0.0)
    v.apply("far", PropertyUpdate(1, {"position": (55.0, 5.0)}), now=0.0)
    v.apply("nowhere", PropertyUpdate(1, {"status": "idle"}), now=0.0)
    assert not v.scoped
    assert v.set_scope(frozenset({(0, 0), (1, 0)})) == ["far"]
    assert v.scoped
    assert v.in_scope("near")
    assert v.in_scope("nowhere")


def test_liveness_reports_silent_nodes_sorted_and_forget_returns_the_last_values() -> None:
    v = view()
    v.apply("c", PropertyUpdate(1, {"status": "idle"}), now=1.0)
    v.heard("b", now=1.5)  # a channel frame: alive, though not in the view
    v.apply("a", PropertyUpdate(1, {"status": "idle"}), now=3.0)
    assert v.silent_since(2.0) == ["b", "c"]
    assert v.knows("b")
    assert "b" not in v
    assert v.forget("c") == {"status": "idle"}
    assert v.forget("c") is None
    assert not v.knows("c")
    assert list(v.mapping) == ["a"]
    assert v.forget("a", keep_liveness=True) == {"status": "idle"}  # out of scope
    assert "a" not in v
    assert v.knows("a")  # when it was last heard stays: its failure is still found
    assert v.silent_since(3.0) == ["a", "b"]


def test_every_message_type_has_a_kind_name() -> None:
    from typing import get_args

    from objectplaces.core.messages import KIND_NAMES, Message

    assert set(KIND_NAMES) == set(get_args(Message))
