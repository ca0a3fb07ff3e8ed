"""One vehicle's VDA 5050 interface, sans I/O: messages in, messages out.

:class:`VdaEndpoint` takes the payloads that arrive on ``order`` and ``instantActions``
and says what to publish: a ``state`` at least every ``state_interval_s`` and at once
after every change, a ``visualization`` every ``visualization_interval_s``, the
``factsheet`` on request. Every incoming message is validated; whatever is wrong with
it becomes an entry in the state's ``errors``, and the vehicle carries on.
"""

from __future__ import annotations

import json
from collections import deque
from dataclasses import dataclass
from typing import Any

from agv_app.vda5050.messages import (
    INSTANT_ACTIONS,
    ActionState,
    Headers,
    factsheet_message,
    state_message,
    visualization_message,
)
from agv_app.vda5050.order import OrderRejected, VdaError
from agv_app.vda5050.topics import VehicleTopics
from agv_app.vda5050.validation import schema_errors
from agv_app.vda5050.vehicle import OrderAgv

__all__ = ["Outgoing", "VdaEndpoint"]

_MAX_ERRORS = 10
_MAX_ACTION_STATES = 50


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
        visualization_interval_s: time between two visualization messages.
    """

    def __init__(
        self,
        agv: OrderAgv,
        topics: VehicleTopics,
        *,
        state_interval_s: float = 1.0,
        visualization_interval_s: float = 0.5,
    ) -> None:
        self.agv = agv
        self.topics = topics
        self.headers = Headers(topics)
        self.state_interval_s = state_interval_s
        self.visualization_interval_s = visualization_interval_s
        self.errors: deque[VdaError] = deque(maxlen=_MAX_ERRORS)
        self.actions: deque[ActionState] = deque(maxlen=_MAX_ACTION_STATES)
        self.received = 0
        self._dirty = True
        self._next_state = 0.0
        self._next_visualization = 0.0
        agv.on_change = self.mark_changed

    def mark_changed(self) -> None:
        """Something the state shows changed: publish a state at the next ``due``."""
        self._dirty = True

    # -- in -----------------------------------------------------------------------------

    def handle(self, subtopic: str, payload: bytes) -> list[Outgoing]:
        """Take a payload that arrived on ``subtopic``; return what to publish at once."""
        self.received += 1
        try:
            message = json.loads(payload)
        except (UnicodeDecodeError, json.JSONDecodeError) as exc:
            self._error(VdaError("validationError", f"{subtopic} is not JSON: {exc}"))
            return []
        if subtopic == "order":
            self._order(message)
            return []
        if subtopic == "instantActions":
            return self._instant_actions(message)
        return []

    def _error(self, error: VdaError) -> None:
        self.errors.append(error)
        self._dirty = True

    def _order(self, message: Any) -> None:
        try:
            outcome = self.agv.receive_order(message)
        except OrderRejected as rejected:
            self._error(rejected.error)
            return
        except Exception as exc:  # a message must never stop the vehicle
            self._error(VdaError("orderError", f"the order could not be taken: {exc!r}"))
            return
        if outcome == "accepted":
            # The errors of earlier orders are resolved by the next order taken.
            self.errors.clear()
        self._dirty = True

    def _instant_actions(self, message: Any) -> list[Outgoing]:
        problems = schema_errors("instantActions", message)
        if problems:
            self._error(VdaError("validationError", "; ".join(problems)))
            return []
        out: list[Outgoing] = []
        for action in message["actions"]:
            out.extend(self._action(str(action["actionId"]), str(action["actionType"])))
        self._dirty = True
        return out

    def _action(self, action_id: str, action_type: str) -> list[Outgoing]:
        agv = self.agv
        ref = (("actionId", action_id),)
        status = "FINISHED"
        out: list[Outgoing] = []
        if action_type not in INSTANT_ACTIONS:
            status = "FAILED"
            self._error(
                VdaError("validationError", f"instant action {action_type!r} is not supported", ref)
            )
        elif action_type == "cancelOrder":
            if agv.cancel_order():
                status = "RUNNING" if agv.cancelling else "FINISHED"
            else:
                status = "FAILED"
                self._error(VdaError("noOrderToCancel", "there is no order to cancel", ref))
        elif action_type == "startPause":
            agv.paused = True
            status = "RUNNING" if agv.driving else "FINISHED"
        elif action_type == "stopPause":
            agv.paused = False
        elif action_type == "factsheetRequest":
            out.append(self.factsheet())
        self.actions.append(ActionState(action_id, action_type, status))
        if action_type == "stateRequest":
            out.append(self._state())
        return out

    def _settle_actions(self) -> None:
        """Finish running actions whose end has come (vehicle stopped, cancel done)."""
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

    # -- out ----------------------------------------------------------------------------

    def _state(self) -> Outgoing:
        message = state_message(
            self.agv, self.headers, errors=list(self.errors), instant_actions=list(self.actions)
        )
        return Outgoing("state", message)

    def factsheet(self) -> Outgoing:
        """The factsheet message (retained, so a master control joining later has it)."""
        message = factsheet_message(self.agv, self.headers, state_interval_s=self.state_interval_s)
        return Outgoing("factsheet", message, qos=1, retain=True)

    def due(self, now: float) -> list[Outgoing]:
        """What to publish at time ``now`` (seconds, any monotonic clock)."""
        self._settle_actions()
        out: list[Outgoing] = []
        if self._dirty or now >= self._next_state:
            self._dirty = False
            self._next_state = now + self.state_interval_s
            out.append(self._state())
        if now >= self._next_visualization:
            self._next_visualization = now + self.visualization_interval_s
            out.append(Outgoing("visualization", visualization_message(self.agv, self.headers)))
        return out
