"""Failed AGVs made known beyond the interest radius.

A crashed AGV stays on the floor. Every node that heard it learns of the failure when
its failure timeout runs out and keeps its last circle as a stale record (the AGV
component does that). With scoped dissemination, an AGV that was out of the failed one's
scope at that moment never heard it, and a crashed node publishes nothing more: driving
up to it later, it would know nothing of it. So a node that hears every node (the
fleet's observer) relays the failures: :class:`StaleRelay` keeps the last circle of
every failed AGV and publishes them as its property ``failed_agvs`` (the node has no
position, so the publication reaches every node); :class:`StaleListener`, on each AGV
node, writes them into the AGV's lock book, and drops one when the relay drops it (its
node was heard again). The interest radius adds the ground an AGV covers while the
relay detects a failure (:func:`agv_app.traffic.reach.interest_radius`), so no AGV gets
close enough to conflict with a failed one before the relay's record reaches it.

Where no process hears every node (vehicles on their own hosts, the control process
perhaps down), every AGV relays the failures it saw itself to the nodes around it
(``agv_app.fleet.agv_process``), and every AGV listens to every relay it hears: a
failure stays recorded while any relay lists it, so no vehicle's safety depends on the
control process.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

from agv_app.protocol import AGV_KIND
from agv_app.traffic.lockbook import LockBook, StaleRecord
from objectplaces import RoleActivator

__all__ = ["FAILED_AGVS", "StaleListener", "StaleRelay"]

FAILED_AGVS = "failed_agvs"
"""The relay's property: ``[[node id, x, y, radius], ...]``, sorted by node id."""

Circle = tuple[float, float, float]


def _circle(props: Mapping[str, Any]) -> Circle | None:
    pos, radius = props.get("position"), props.get("hull_length")
    if isinstance(pos, tuple | list) and len(pos) == 2 and isinstance(radius, int | float):
        return (float(pos[0]), float(pos[1]), float(radius))
    return None


class StaleRelay:
    """Publishes the last circle of every failed AGV a node that hears all nodes saw fail.

    Args:
        node: a node without an interest radius and without a position.
    """

    def __init__(self, node: RoleActivator) -> None:
        self.node = node
        self.failed: dict[str, Circle] = {}
        """Failed AGVs not heard since, by node id."""
        node.register_node_departure_observer(self._departed)
        node.register_node_property_observer(self._property, names=("hull_length",))
        self._publish()

    def _departed(self, node_id: str, last: Mapping[str, Any]) -> None:
        circle = _circle(last)
        if last.get("kind") == AGV_KIND and circle is not None:
            self.failed[node_id] = circle
            self._publish()

    def _property(self, node_id: str, name: str, value: Any) -> None:
        if name == "hull_length" and self.failed.pop(node_id, None) is not None:
            self._publish()

    def _publish(self) -> None:
        value = [[n, *circle] for n, circle in sorted(self.failed.items())]
        self.node.update_node_property(FAILED_AGVS, value)


class StaleListener:
    """Writes the failed AGVs the relays it hears publish into this AGV's lock book.

    Args:
        node: the AGV's node.
        book: the AGV's lock book, read anew on every change (the node may restart).
    """

    def __init__(self, node: RoleActivator, book: Callable[[], LockBook]) -> None:
        self.node_id = node.node_id
        self._book = book
        self._by_relay: dict[str, dict[str, Circle]] = {}
        node.register_node_property_observer(self._property, names=(FAILED_AGVS,))

    def _property(self, node_id: str, name: str, value: Any) -> None:
        if name != FAILED_AGVS or node_id == self.node_id or not isinstance(value, list):
            return
        listed: dict[str, Circle] = {}
        for item in value:
            if isinstance(item, list | tuple) and len(item) == 4 and isinstance(item[0], str):
                failed, *rest = item
                if failed != self.node_id and all(isinstance(v, int | float) for v in rest):
                    listed[failed] = (float(rest[0]), float(rest[1]), float(rest[2]))
        before = self._known()
        if listed:
            self._by_relay[node_id] = listed
        else:
            self._by_relay.pop(node_id, None)
        after = self._known()
        book = self._book()
        for failed in before.keys() - after.keys():
            book.drop_stale(failed)
        for failed, (x, y, r) in sorted(after.items()):
            if before.get(failed) != (x, y, r):
                book.add_stale(StaleRecord(failed, x, y, r))

    def _known(self) -> dict[str, Circle]:
        """Every failure some relay lists (the latest relay's circle where two differ)."""
        known: dict[str, Circle] = {}
        for relay in sorted(self._by_relay):
            known.update(self._by_relay[relay])
        return known
