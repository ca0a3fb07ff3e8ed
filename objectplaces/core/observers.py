"""Application observers of properties and departures.

Observers are application code, so the machine never calls them while it decides:
each notification is queued in the outbox as a callback and runs when the driver
drains the machine, after the state change it reports is complete. An observer that
inspects the node from its callback therefore sees the change already applied (a
departed node already gone from the view), and one that raises cannot leave the
machine half-updated.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

from objectplaces.core.outbox import Outbox

__all__ = ["DepartureObserver", "Observers", "PropertyObserver"]

PropertyObserver = Callable[[str, str, Any], Any]
DepartureObserver = Callable[[str, Mapping[str, Any]], Any]


class Observers:
    """Registered observers, notified through the outbox.

    Args:
        outbox: where notifications are queued.
    """

    __slots__ = ("_departure", "_outbox", "_property", "watching_properties")

    def __init__(self, outbox: Outbox) -> None:
        self._outbox = outbox
        self._property: list[PropertyObserver] = []
        self._departure: list[DepartureObserver] = []
        #: Whether any property observer is registered: a plain attribute, read for every
        #: received update, so the hot path skips all notification work when nobody watches.
        self.watching_properties = False

    def add_property(self, observer: PropertyObserver) -> Callable[[], None]:
        """Register ``observer(node_id, name, value)``; returns its cancel function."""
        self._property.append(observer)
        self.watching_properties = True

        def cancel() -> None:
            _discard(self._property, observer)
            self.watching_properties = bool(self._property)

        return cancel

    def add_departure(self, observer: DepartureObserver) -> Callable[[], None]:
        """Register ``observer(node_id, last_properties)``; returns its cancel function."""
        self._departure.append(observer)
        return lambda: _discard(self._departure, observer)

    def property_changed(self, node: str, name: str, value: Any) -> None:
        """Queue a notification of one changed property for every property observer."""
        for observer in self._property:
            self._outbox.call(observer, (node, name, value))

    def departed(self, node: str, last: Mapping[str, Any]) -> None:
        """Queue a notification of a departure, with a copy of the last properties."""
        for observer in self._departure:
            self._outbox.call(observer, (node, dict(last)))


def _discard(items: list[Any], item: Any) -> None:
    if item in items:
        items.remove(item)
