"""One vehicle's VDA 5050 interface, sans I/O: messages in, messages out.

:class:`VdaEndpoint` takes the payloads that arrive on ``order`` and ``instantActions``
and says what to publish: a ``state`` at once after every change and at least every
``state_interval_s``, but never two within ``min_state_interval_s`` (the factsheet's
``minimumStateInterval``: changes that come sooner share the next state); a
``visualization`` every ``visualization_interval_s``; the ``factsheet`` on request.
Every incoming message is validated; whatever is wrong with it becomes an entry in the
state's ``errors`` with a VDA 5050 3.0 type (:mod:`agv_app.vda5050.reports`), and the
vehicle carries on.

Errors stay as long as the 3.0 text says (section 6.6.5.4, "Report duration"): an
order's until a new order is taken, ``INVALID_INSTANT_ACTION`` until an instant action
is taken, ``INSTANT_ACTION_STATES_FULL`` until ``clearInstantActions``. Instant action
states stay until ``clearInstantActions`` (section 7.8); the vehicle keeps
``max_instant_action_states`` of them, and says so with ``INSTANT_ACTION_STATES_FULL``
when it has to let the oldest ended one go.
"""

from __future__ import annotations

import json
import math
from collections import deque
from dataclasses import dataclass
from typing import Any, Final

from agv_app.vda5050.actions import CATALOGUE, OrderAction
from agv_app.vda5050.messages import (
    MAX_ERRORS_LISTED,
    ActionState,
    Headers,
    factsheet_message,
    state_message,
    visualization_message,
)
from agv_app.vda5050.order import OrderRejected
from agv_app.vda5050.reports import (
    INSTANT_ACTION_STATES_FULL,
    INVALID_INSTANT_ACTION,
    NO_ORDER_TO_CANCEL,
    URGENT,
    VALIDATION_FAILURE,
    VdaError,
)
from agv_app.vda5050.topics import VehicleTopics
from agv_app.vda5050.validation import schema_errors
from agv_app.vda5050.vehicle import OrderAgv

__all__ = [
    "DEFAULT_STATE_INTERVAL_S",
    "MAX_ERRORS",
    "MAX_INSTANT_ACTION_STATES",
    "MIN_STATE_INTERVAL_S",
    "VISUALIZATION_INTERVAL_S",
    "Outgoing",
    "VdaEndpoint",
]

MAX_ERRORS: Final = MAX_ERRORS_LISTED
"""The most errors a state lists (the oldest go first)."""

MAX_INSTANT_ACTION_STATES: Final = 200
"""The most instant action states a vehicle keeps."""

MIN_STATE_INTERVAL_S: Final = 0.05
"""The shortest time between two states."""

DEFAULT_STATE_INTERVAL_S: Final = 1.0
"""The longest time between two states."""

VISUALIZATION_INTERVAL_S: Final = 0.5
"""The time between two visualization messages."""

_POSE_KEYS: Final = ("x", "y", "theta", "mapId", "lastNodeId")
# What stays when a new order is taken: the errors whose report ends otherwise.
_NOT_ABOUT_ORDERS: Final = frozenset({INVALID_INSTANT_ACTION, INSTANT_ACTION_STATES_FULL})


@dataclass(frozen=True, slots=True)
class Outgoing:
    """A message to publish on one of the vehicle's subtopics."""

    subtopic: str
    message: dict[str, Any]
    qos: int = 0
    retain: bool = False

    def payload(self) -> bytes:
        """The message as UTF-8 JSON."""
        return json.dumps(self.message, separators=(",", ":")).encode()


class VdaEndpoint:
    """What one vehicle says and hears over VDA 5050.

    Args:
        agv: the vehicle (its ``on_change`` is taken over to mark the state dirty).
        topics: its topics (manufacturer and serial number).
        state_interval_s: longest time between two states.
        min_state_interval_s: shortest time between two states.
        visualization_interval_s: time between two visualization messages.
        max_instant_action_states: instant action states kept at most.
    """

    def __init__(
        self,
        agv: OrderAgv,
        topics: VehicleTopics,
        *,
        state_interval_s: float = DEFAULT_STATE_INTERVAL_S,
        min_state_interval_s: float = MIN_STATE_INTERVAL_S,
        visualization_interval_s: float = VISUALIZATION_INTERVAL_S,
        max_instant_action_states: int = MAX_INSTANT_ACTION_STATES,
    ) -> None:
        self.agv = agv
        self.topics = topics
        self.headers = Headers(topics)
        self.state_interval_s = state_interval_s
        self.min_state_interval_s = min_state_interval_s
        self.visualization_interval_s = visualization_interval_s
        self.max_instant_action_states = max_instant_action_states
        self.errors: deque[VdaError] = deque(maxlen=MAX_ERRORS)
        self.actions: list[ActionState] = []
        """``instantActionStates``, oldest first."""
        self.received = 0
        self._dirty = True
        self._last_state = -math.inf
        self._next_visualization = 0.0
        agv.on_change = self.mark_changed

    def mark_changed(self) -> None:
        """Something the state shows changed: publish a state as soon as it may go."""
        self._dirty = True

    # -- in -----------------------------------------------------------------------------

    def handle(self, subtopic: str, payload: bytes, *, now: float | None = None) -> list[Outgoing]:
        """Take a payload that arrived on ``subtopic``; return what to publish at once.

        ``now`` (the clock of :meth:`due`) lets a requested state go at once when the
        last one is old enough; without it, it goes at the next :meth:`due`.
        """
        self.received += 1
        try:
            message = json.loads(payload)
        except (UnicodeDecodeError, json.JSONDecodeError) as exc:
            self._error(VdaError(VALIDATION_FAILURE, f"{subtopic} is not JSON: {exc}"))
            return []
        if subtopic == "order":
            self._order(message)
            return []
        if subtopic == "instantActions":
            return self._instant_actions(message, now)
        return []

    def _error(self, error: VdaError) -> None:
        self.errors.append(error)
        self._dirty = True

    def _drop_errors(self, *types: str) -> None:
        kept = [e for e in self.errors if e.error_type not in types]
        if len(kept) != len(self.errors):
            self.errors = deque(kept, maxlen=MAX_ERRORS)
            self._dirty = True

    def _order(self, message: Any) -> None:
        try:
            outcome = self.agv.receive_order(message)
        except OrderRejected as rejected:
            self._error(rejected.error)
            return
        except Exception as exc:  # a message must never stop the vehicle
            self._error(VdaError(VALIDATION_FAILURE, f"the order could not be taken: {exc!r}"))
            return
        if outcome == "accepted":
            # The errors of earlier orders end with the next order taken.
            kept = [e for e in self.errors if e.error_type in _NOT_ABOUT_ORDERS]
            self.errors = deque(kept, maxlen=MAX_ERRORS)
        self._dirty = True

    def _instant_actions(self, message: Any, now: float | None) -> list[Outgoing]:
        problems = schema_errors("instantActions", message)
        if problems:
            self._error(VdaError(VALIDATION_FAILURE, "; ".join(problems)))
            return []
        out: list[Outgoing] = []
        known = {a.action_id for a in self.actions}
        for action in message["actions"]:
            action_id = str(action["actionId"])
            if action_id in known:
                continue  # the same instant action again: carried out once
            known.add(action_id)
            parameters = {str(p["key"]): p["value"] for p in action.get("actionParameters", [])}
            out.extend(self._action(action_id, str(action["actionType"]), parameters))
        self._dirty = True
        if self._state_due(now):
            assert now is not None
            out.append(self._state(now))
        return out

    def _action(
        self, action_id: str, action_type: str, parameters: dict[str, Any]
    ) -> list[Outgoing]:
        agv = self.agv
        ref = (("actionId", action_id),)
        spec = CATALOGUE.get(action_type)
        if spec is None or "INSTANT" not in spec.scopes:
            self._add(ActionState(action_id, action_type, "FAILED"))
            self._error(
                VdaError(
                    INVALID_INSTANT_ACTION,
                    f"the vehicle carries out no instant action {action_type!r}",
                    ref,
                )
            )
            return []
        self._drop_errors(INVALID_INSTANT_ACTION)
        status, result, out = "FINISHED", "", []
        problem: VdaError | None = None
        now = agv.node.now()
        match action_type:
            case "cancelOrder":
                wanted = parameters.get("orderId")
                book = agv.book_of_orders
                if (wanted is not None and wanted != book.order_id) or not agv.cancel_order():
                    status = "FAILED"
                    why = "there is no order to cancel"
                    if wanted is not None and wanted != book.order_id:
                        why = f"order {wanted!r} is not the vehicle's ({book.order_id!r})"
                    problem = VdaError(NO_ORDER_TO_CANCEL, why, ref)
                elif agv.cancelling:
                    status = "RUNNING"
            case "startPause":
                agv.pause()
                status = "RUNNING" if agv.driving else "FINISHED"
            case "stopPause":
                agv.resume()
            case "startCharging" | "stopCharging":
                begun = agv.handling.begin(
                    OrderAction(action_id, action_type, "NONE", agv.point, -1), now
                )
                if isinstance(begun, VdaError):
                    status, problem = (
                        "FAILED",
                        VdaError(INVALID_INSTANT_ACTION, begun.description, ref),
                    )
                else:
                    result = "charging" if agv.battery.charging else "not charging"
            case "factsheetRequest":
                out.append(self.factsheet())
            case "stateRequest":
                self._dirty = True
            case "clearInstantActions":
                self.actions = [a for a in self.actions if a.status not in ("FINISHED", "FAILED")]
                self._drop_errors(INSTANT_ACTION_STATES_FULL)
            case "initializePosition" | "initPosition":
                refused = _pose_problem(parameters)
                if refused is None:
                    refused = agv.initialize_position(
                        float(parameters["x"]),
                        float(parameters["y"]),
                        str(parameters["mapId"]),
                        str(parameters["lastNodeId"]),
                    )
                if refused is not None:
                    status, problem = (
                        "FAILED",
                        VdaError(INVALID_INSTANT_ACTION, f"{action_type}: {refused}", ref),
                    )
        self._add(ActionState(action_id, action_type, status, result))
        if problem is not None:
            self._error(problem)
        return out

    def _add(self, state: ActionState) -> None:
        """List an instant action's state, letting the oldest ended one go when full."""
        if len(self.actions) >= self.max_instant_action_states:
            ended = [i for i, a in enumerate(self.actions) if a.status in ("FINISHED", "FAILED")]
            del self.actions[ended[0] if ended else 0]
            if not any(e.error_type == INSTANT_ACTION_STATES_FULL for e in self.errors):
                self._error(
                    VdaError(
                        INSTANT_ACTION_STATES_FULL,
                        f"instantActionStates holds {self.max_instant_action_states}: the "
                        "oldest ended ones go; send clearInstantActions",
                        level=URGENT,
                    )
                )
        self.actions.append(state)

    def _settle(self) -> None:
        """Finish running instant actions whose end has come; collect the errors of order
        actions that failed."""
        agv = self.agv
        for i, action in enumerate(self.actions):
            if action.status != "RUNNING":
                continue
            done = (action.action_type == "cancelOrder" and not agv.cancelling) or (
                action.action_type == "startPause" and not agv.driving
            )
            if done:
                self.actions[i] = ActionState(action.action_id, action.action_type, "FINISHED")
                self._dirty = True
        for error in agv.book_of_orders.actions.take_errors():
            self._error(error)

    # -- out ----------------------------------------------------------------------------

    def _state_due(self, now: float | None) -> bool:
        if now is None or not self._dirty:
            return False
        return now >= self._last_state + self.min_state_interval_s

    def _state(self, now: float) -> Outgoing:
        self._dirty = False
        self._last_state = now
        return Outgoing("state", self.state_now())

    def state_now(self) -> dict[str, Any]:
        """The state message as it would go now (takes the next ``state`` headerId)."""
        return state_message(
            self.agv, self.headers, errors=list(self.errors), instant_actions=list(self.actions)
        )

    def factsheet(self) -> Outgoing:
        """The factsheet message: QoS 0 (VDA 5050 3.0 section 4.1) and retained (6.10),
        so a master control joining later has it."""
        message = factsheet_message(
            self.agv,
            self.headers,
            state_interval_s=self.state_interval_s,
            min_state_interval_s=self.min_state_interval_s,
            visualization_interval_s=self.visualization_interval_s,
            max_instant_action_states=self.max_instant_action_states,
        )
        return Outgoing("factsheet", message, qos=0, retain=True)

    def due(self, now: float) -> list[Outgoing]:
        """What to publish at time ``now`` (seconds, any monotonic clock)."""
        self._settle()
        out: list[Outgoing] = []
        if self._state_due(now) or now >= self._last_state + self.state_interval_s:
            out.append(self._state(now))
        if now >= self._next_visualization:
            self._next_visualization = now + self.visualization_interval_s
            out.append(Outgoing("visualization", visualization_message(self.agv, self.headers)))
        return out


def _pose_problem(parameters: dict[str, Any]) -> str | None:
    """What is missing or ill-typed among an initializePosition's parameters."""
    missing = [k for k in _POSE_KEYS if k not in parameters]
    if missing:
        return f"parameters {', '.join(missing)} missing"
    for key in ("x", "y", "theta"):
        value = parameters[key]
        number = isinstance(value, int | float) and not isinstance(value, bool)
        if not number or not math.isfinite(value):
            return f"parameter {key} must be a number, got {value!r}"
    for key in ("mapId", "lastNodeId"):
        if not isinstance(parameters[key], str):
            return f"parameter {key} must be a string, got {parameters[key]!r}"
    return None
