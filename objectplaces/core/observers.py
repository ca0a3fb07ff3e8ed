"""Application observers of properties and departures.

Observers are application code, so the machine never calls them while it decides:
each notification is queued in the outbox as a callback and runs when the driver
drains the machine, after the state change it reports is complete. An observer that
inspects the node from its callback therefore sees the change already applied (a
departed node already gone from the view), and one that raises cannot leave the
machine half-updated.

A property observer may name the properties it wants. A change of any other property
then queues nothing for it: on a floor where every node hears every other, most
changes are of properties an observer would only look at and drop. Observers are
notified in the order they registered, whichever form they took.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from typing import Any

from objectplaces.core.outbox import Outbox

__all__ = ["DepartureObserver", "Observers", "PropertyObserver"]

PropertyObserver = Callable[[str, str, Any], Any]
DepartureObserver = Callable[[str, Mapping[str, Any]], Any]


class _Registration:
    """One registration of a property observer: an object of its own, so that a cancel
    finds its own registration by identity even when the observer registered twice."""

    __slots__ = ("names", "observer")

    def __init__(self, observer: PropertyObserver, names: frozenset[str] | None) -> None:
        self.observer = observer
        self.names = names


_ROUTES_MAX = 1024  # property names whose observer list is remembered at once


class Observers:
    """Registered observers, notified through the outbox.

    Args:
        outbox: where notifications are queued.
    """

    __slots__ = ("_departure", "_outbox", "_property", "_routes", "watching_properties")

    def __init__(self, outbox: Outbox) -> None:
        self._outbox = outbox
        #: Property observers in registration order, each with the names it wants
        #: (None: every property).
        self._property: list[_Registration] = []
        #: The observers of one property name, worked out from ``_property`` at its
        #: first change and forgotten whenever an observer comes or goes.
        self._routes: dict[str, tuple[PropertyObserver, ...]] = {}
        self._departure: list[DepartureObserver] = []
        #: Whether any property observer is registered: a plain attribute, read for every
        #: received update, so the hot path skips all notification work when nobody watches.
        self.watching_properties = False

    def add_property(
        self, observer: PropertyObserver, names: Iterable[str] | None = None
    ) -> Callable[[], None]:
        """Register ``observer(node_id, name, value)`` for the properties ``names``
        (None: every property); returns its cancel function.

        Raises:
            TypeError: ``names`` is a single string (a name is not a list of names).
        """
        if isinstance(names, str):
            raise TypeError(f"names must be a collection of names, not the string {names!r}")
        registration = _Registration(observer, None if names is None else frozenset(names))
        self._property.append(registration)
        self._routes.clear()
        self.watching_properties = True

        def cancel() -> None:
            # The registration itself, not an equal one: the same observer may be
            # registered twice, and each cancel takes back its own.
            for i, item in enumerate(self._property):
                if item is registration:
                    del self._property[i]
                    break
            self._routes.clear()
            self.watching_properties = bool(self._property)

        return cancel

    def add_departure(self, observer: DepartureObserver) -> Callable[[], None]:
        """Register ``observer(node_id, last_properties)``; returns its cancel function."""
        self._departure.append(observer)
        return lambda: _discard(self._departure, observer)

    def property_changed(self, node: str, name: str, value: Any) -> None:
        """Queue a notification of one changed property for every observer of it."""
        observers = self._routes.get(name)
        if observers is None:
            observers = self._route(name)
        for observer in observers:
            self._outbox.call(observer, (node, name, value))

    def _route(self, name: str) -> tuple[PropertyObserver, ...]:
        observers = tuple(r.observer for r in self._property if r.names is None or name in r.names)
        if len(self._routes) >= _ROUTES_MAX:
            self._routes.clear()
        self._routes[name] = observers
        return observers

    def departed(self, node: str, last: Mapping[str, Any]) -> None:
        """Queue a notification of a departure, with a copy of the last properties."""
        for observer in self._departure:
            self._outbox.call(observer, (node, dict(last)))


def _discard(items: list[Any], item: Any) -> None:
    if item in items:
        items.remove(item)
