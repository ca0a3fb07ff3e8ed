"""OwnProperties alone: coalescing, sequence numbers, routing to cells, subscriptions."""

from __future__ import annotations

from objectplaces.core import codec
from objectplaces.core.config import NodeConfig
from objectplaces.core.events import Broadcast, Output, Publish, Send
from objectplaces.core.messages import PropertyUpdate
from objectplaces.core.own import OwnProperties


def decoded(output: Output | None) -> PropertyUpdate:
    assert isinstance(output, Broadcast | Publish | Send)
    message = codec.decode(output.data)
    assert isinstance(message, PropertyUpdate)
    return message


def test_changes_in_one_instant_leave_as_one_frame() -> None:
    own = OwnProperties(NodeConfig())
    assert own.take_update() is None
    own.set("status", "idle")
    own.set("status", "busy")
    own.set("kind", "agv")
    assert own.pending
    update = own.take_update()
    assert isinstance(update, Broadcast)
    # Everything there is: a snapshot, which spares receivers a request (§5).
    assert decoded(update) == PropertyUpdate(1, {"status": "busy", "kind": "agv"}, full=True)
    assert not own.pending
    assert own.take_update() is None


def test_publications_are_numbered_without_gaps_and_republish_sends_everything() -> None:
    own = OwnProperties(NodeConfig())
    own.set("a", 1)
    own.take_update()
    own.set("b", 2)
    # A snapshot for one peer takes the latest publication's number, not a new one.
    assert decoded(own.full_update_for("x")) == PropertyUpdate(1, {"a": 1, "b": 2}, full=True)
    assert decoded(own.republish()) == PropertyUpdate(2, {"a": 1, "b": 2}, full=True)
    own.set("b", 3)
    assert decoded(own.take_update()) == PropertyUpdate(3, {"b": 3})  # a delta
    assert not own.pending  # the republication carried the pending change
    assert own.take_update() is None
    assert decoded(own.republish()).seq == 4


def test_nothing_to_republish_or_sync_before_any_property() -> None:
    own = OwnProperties(NodeConfig(property_interval=1.0))
    assert own.republish() is None
    assert own.full_update_for("x") is None


def test_a_move_to_another_cell_is_published_to_both_cells() -> None:
    own = OwnProperties(NodeConfig(interest_radius=5.0, cell_size=10.0))
    own.set("position", (5.0, 5.0))
    first = own.take_update()
    assert isinstance(first, Publish)
    assert first.cells == ((0, 0),)
    own.set("status", "idle")
    own.take_update()
    own.set("position", (15.0, 5.0))
    moved = own.take_update()
    assert isinstance(moved, Publish)
    assert moved.cells == ((1, 0), (0, 0))  # the old cell's subscribers learn it left
    # The old cell's subscribers heard it: a delta. The new cell's may never have heard
    # of it: they get everything, the same publication as a snapshot.
    assert decoded(moved) == PropertyUpdate(3, {"position": (15.0, 5.0)})
    assert moved.snapshot is not None
    snapshot = codec.decode(moved.snapshot)
    assert snapshot == PropertyUpdate(3, {"position": (15.0, 5.0), "status": "idle"}, full=True)
    own.set("position", (16.0, 5.0))
    same = own.take_update()
    assert isinstance(same, Publish)
    assert same.cells == ((1, 0),)
    assert decoded(same) == PropertyUpdate(4, {"position": (16.0, 5.0)})


def test_without_a_position_a_scoped_node_broadcasts() -> None:
    own = OwnProperties(NodeConfig(interest_radius=5.0))
    own.set("status", "idle")
    assert isinstance(own.take_update(), Broadcast)


def square(x0: int, y0: int, x1: int, y1: int) -> frozenset[tuple[int, int]]:
    return frozenset((x, y) for x in range(x0, x1 + 1) for y in range(y0, y1 + 1))


def test_the_subscription_is_announced_only_when_its_cells_change() -> None:
    own = OwnProperties(NodeConfig(interest_radius=10.0, cell_size=10.0))
    got = []
    for position in [(5.0, 5.0), (6.0, 5.0), (12.0, 5.0)]:
        own.set("position", position)
        got.append(own.new_subscription())
    assert got == [square(-1, -1, 1, 1), None, square(0, -1, 2, 1)]


def test_full_dissemination_never_subscribes_to_cells() -> None:
    own = OwnProperties(NodeConfig())
    own.set("position", (1.0, 1.0))
    assert own.new_subscription() is None
