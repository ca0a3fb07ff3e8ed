"""What a vehicle reports in its state's ``errors``: the VDA 5050 3.0 error types and levels.

The types are those the 3.0 text predefines (section 6.6.5.4, "Predefined error
types"), with the level the text gives each; the rejection scenarios of section 6.1.4
say which one an order gets. The two not in that table are the text's own too:
``INSTANT_ACTION_STATES_FULL`` (section 7.8, ``instantActionStates``) and
``LOAD_HANDLING_FAILED``, this vehicle's own type for a pick or drop that failed (the
text asks that a failed pick or drop "correspond with an error" and leaves its type to
the vehicle; ``errorType`` is an extensible enumeration).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Final

__all__ = [
    "CRITICAL",
    "ERROR_LEVELS",
    "FATAL",
    "INSTANT_ACTION_STATES_FULL",
    "INVALID_INSTANT_ACTION",
    "INVALID_ORDER_ACTION",
    "LOAD_HANDLING_FAILED",
    "MOBILE_ROBOT_NOT_AVAILABLE",
    "NO_ORDER_TO_CANCEL",
    "NO_ROUTE_TO_TARGET",
    "ORDER_UPDATE_FOLLOWING_CANCEL",
    "OTHER_ORDER_ACTIVE",
    "OUTDATED_ORDER_UPDATE",
    "SAME_ORDER_UPDATE_ID",
    "START_NODE_OUT_OF_RANGE",
    "UNKNOWN_MAP_ID",
    "UNSUPPORTED_PARAMETER",
    "URGENT",
    "VALIDATION_FAILURE",
    "WARNING",
    "VdaError",
]

WARNING: Final = "WARNING"
"""The vehicle carries on and takes new orders."""
URGENT: Final = "URGENT"
"""Needs attention soon; the vehicle carries on and takes new orders."""
CRITICAL: Final = "CRITICAL"
"""The vehicle cannot go on with its order, but takes a new one."""
FATAL: Final = "FATAL"
"""The vehicle needs someone; it takes no order."""

ERROR_LEVELS: Final = (WARNING, URGENT, CRITICAL, FATAL)
"""Every level, least severe first."""

VALIDATION_FAILURE: Final = "VALIDATION_FAILURE"
"""A malformed order (6.1.4.1): not JSON, against the schema, for another vehicle,
sequence ids that do not fit."""
UNSUPPORTED_PARAMETER: Final = "UNSUPPORTED_PARAMETER"
"""An order with an optional field the vehicle cannot use (6.1.4.2; level CRITICAL)."""
INVALID_ORDER_ACTION: Final = "INVALID_ORDER_ACTION"
"""An order with an action the vehicle cannot perform (6.1.4.3)."""
OUTDATED_ORDER_UPDATE: Final = "OUTDATED_ORDER_UPDATE"
"""The current orderId with a lower orderUpdateId (6.1.4.4)."""
SAME_ORDER_UPDATE_ID: Final = "SAME_ORDER_UPDATE_ID"
"""The current orderId and orderUpdateId again, with other content (6.1.4.5)."""
OTHER_ORDER_ACTIVE: Final = "OTHER_ORDER_ACTIVE"
"""A new orderId while an order is still active (6.1.4.6)."""
START_NODE_OUT_OF_RANGE: Final = "START_NODE_OUT_OF_RANGE"
"""An order whose first node is not where the vehicle is (6.1.4.7)."""
NO_ROUTE_TO_TARGET: Final = "NO_ROUTE_TO_TARGET"
"""An order with a node the vehicle cannot reach (6.1.4.8)."""
MOBILE_ROBOT_NOT_AVAILABLE: Final = "MOBILE_ROBOT_NOT_AVAILABLE"
"""An order while the vehicle takes none (6.1.4.9)."""
UNKNOWN_MAP_ID: Final = "UNKNOWN_MAP_ID"
"""An order with a node on a map the vehicle does not know (6.1.4.10)."""
ORDER_UPDATE_FOLLOWING_CANCEL: Final = "ORDER_UPDATE_FOLLOWING_CANCEL"
"""An update of an order that was cancelled (6.1.3.1)."""
NO_ORDER_TO_CANCEL: Final = "NO_ORDER_TO_CANCEL"
"""``cancelOrder`` without an active order, or for another orderId (6.1.3.2)."""
INVALID_INSTANT_ACTION: Final = "INVALID_INSTANT_ACTION"
"""An instant action the vehicle cannot carry out (6.2.1)."""
INSTANT_ACTION_STATES_FULL: Final = "INSTANT_ACTION_STATES_FULL"
"""``instantActionStates`` holds as many as the vehicle keeps (7.8; level URGENT)."""
LOAD_HANDLING_FAILED: Final = "LOAD_HANDLING_FAILED"
"""A pick or drop failed (a pick with a load on board, a drop without one)."""


@dataclass(frozen=True, slots=True)
class VdaError:
    """One entry of a state's ``errors``.

    Attributes:
        error_type: one of this module's types.
        description: what went wrong, for people.
        references: ``(referenceKey, referenceValue)`` pairs, e.g. ``("nodeId", "P1")``.
        level: one of :data:`ERROR_LEVELS`.
    """

    error_type: str
    description: str
    references: tuple[tuple[str, str], ...] = ()
    level: str = WARNING

    def to_json(self) -> dict[str, Any]:
        """The entry as the state message carries it."""
        return {
            "errorType": self.error_type,
            "errorLevel": self.level,
            "errorDescription": self.description,
            "errorReferences": [
                {"referenceKey": k, "referenceValue": v} for k, v in self.references
            ],
        }
