"""Sending AGV processes home: the control asks over the observer's property, each
vehicle acts once and says so.

The simulated fleet sends a controller home directly
(:func:`~agv_app.vehicle.service.send_home`). A fleet of AGV processes keeps the
requests not yet answered in :class:`SendHomeOrders` and publishes them as the
observer's property ``send_home`` (:data:`SEND_HOME_PROPERTY`): ``[[vehicle id,
number], ...]``, one number per request, counting up. Every AGV process follows it with
a :class:`SendHomeListener`: for a number it has not acted on, it goes home (or refuses:
loaded by then, or failed) and publishes the number as its own property ``sent_home``
(:data:`SENT_HOME_PROPERTY`); the control drops the request once it hears that, so a
process that restarts later does not go home again, and one that restarts before it
answered still does. As with the stop (:mod:`agv_app.fleet.holding`), a listener takes
the property from the observer alone.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from agv_app.fleet.control_word import ControlWord
from agv_app.fleet.view import OBSERVER_ID
from objectplaces import RoleActivator

__all__ = [
    "SEND_HOME_PROPERTY",
    "SENT_HOME_PROPERTY",
    "SendHomeListener",
    "SendHomeOrders",
    "asked_in",
]

SEND_HOME_PROPERTY = "send_home"
"""The observer's property: ``[[vehicle id, request number], ...]`` not yet answered."""

SENT_HOME_PROPERTY = "sent_home"
"""An AGV's property: the number of the last request to go home it acted on."""


class SendHomeOrders:
    """The requests to go home that no vehicle has answered yet, by vehicle id."""

    def __init__(self) -> None:
        self.pending: dict[str, int] = {}
        """Vehicle id -> the number of its request."""
        self._count = 0

    def ask(self, vehicle_id: str) -> int:
        """A new request for ``vehicle_id`` (it replaces one not answered); its number."""
        self._count += 1
        self.pending[vehicle_id] = self._count
        return self._count

    def answered(self, vehicle_id: str, value: Any) -> bool:
        """``vehicle_id`` published ``value`` as its :data:`SENT_HOME_PROPERTY`: True if
        that answers its pending request (which is dropped)."""
        if self.pending.get(vehicle_id) != value:
            return False
        del self.pending[vehicle_id]
        return True

    def wire(self) -> list[list[Any]]:
        """The form the observer publishes as :data:`SEND_HOME_PROPERTY`."""
        return [[vehicle_id, n] for vehicle_id, n in sorted(self.pending.items())]


def asked_in(value: Any, vehicle_id: str) -> int | None:
    """The number of the request for ``vehicle_id`` in the wire form ``value`` (None:
    none, or ``value`` is malformed)."""
    if not isinstance(value, list | tuple):
        return None
    for entry in value:
        if (
            isinstance(entry, list | tuple)
            and len(entry) == 2
            and entry[0] == vehicle_id
            and isinstance(entry[1], int)
            and not isinstance(entry[1], bool)
        ):
            return entry[1]
    return None


class SendHomeListener:
    """An AGV's ear for the control's requests to go home (the module docstring).

    Args:
        node: the AGV's node.
        go_home: sends the AGV home (:func:`~agv_app.vehicle.service.send_home`);
            ValueError says why it cannot go now.
        control_id: the only node whose word counts (the observer).
    """

    def __init__(
        self,
        node: RoleActivator,
        go_home: Callable[[], object],
        *,
        control_id: str = OBSERVER_ID,
    ) -> None:
        self.node = node
        self.go_home = go_home
        self.declined: list[str] = []
        """Why requests the vehicle could not follow were declined (loaded, failed)."""
        self._acted: int | None = None
        self.word = ControlWord(node, SEND_HOME_PROPERTY, self._heard, control_id=control_id)

    @property
    def refused(self) -> int:
        """Requests from another node than the control, ignored."""
        return self.word.refused

    def _heard(self, value: Any) -> bool:
        number = asked_in(value, self.node.node_id)
        if number is not None and number != self._acted:
            self._acted = number
            # Not from inside the view's update: going home publishes properties of its own.
            self.node.call_later(0.0, lambda: self._go(number))
        return True

    def _go(self, number: int) -> None:
        try:
            self.go_home()
        except ValueError as exc:
            self.declined.append(str(exc))
        self.node.update_node_property(SENT_HOME_PROPERTY, number)
