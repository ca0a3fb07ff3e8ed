"""The actions of an order, sans I/O: their states, blocking types and queue.

:data:`CATALOGUE` (:mod:`agv_app.vda5050.catalogue`, re-exported here) lists every
action the vehicle carries out, with its scopes, blocking types, parameters and whether
it can be paused or cancelled.

:class:`ActionBook` keeps the ``actionStates`` of the order, as VDA 5050 3.0 section
6.2.2 ("Action blocking types and sequence") and Figure 11 say: an action is 'WAITING'
until its node is traversed; then it joins a queue in the order of the node's
``actions``. The queue is worked through from its head: 'NONE' and 'SOFT' actions start
together, a 'SINGLE' or 'HARD' one starts only once every action started before it has
ended, and nothing behind it starts until it has. While any action in the queue is
'SOFT' or 'HARD' the vehicle does not drive. What an action does is the
:class:`Effects`' business: it starts an action (how long it runs) and completes it
(its result, or the error it failed with). Times are the vehicle's clock, passed in.

Pausing (``startPause``) pauses the running actions that allow it (their time left is
kept) and starts no new ones; cancelling (``cancelOrder``, 6.1.3) fails every action
not started, and every running one that allows it; the others run to their end.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Final, Protocol

from agv_app.vda5050.catalogue import BLOCKING_TYPES, CATALOGUE, ActionSpec, ParameterSpec
from agv_app.vda5050.reports import VdaError

__all__ = [
    "BLOCKING_TYPES",
    "CATALOGUE",
    "ENDED",
    "ActionBook",
    "ActionRecord",
    "ActionSpec",
    "Effects",
    "OrderAction",
    "ParameterSpec",
]

ENDED: Final = frozenset({"FINISHED", "FAILED"})
"""The statuses an action does not leave."""

_STOPPING: Final = frozenset({"SOFT", "HARD"})
_ALONE: Final = frozenset({"SINGLE", "HARD"})


@dataclass(frozen=True, slots=True)
class OrderAction:
    """An action of an order's node.

    Attributes:
        action_id: its ``actionId``.
        action_type: its ``actionType`` (one of :data:`CATALOGUE`).
        blocking_type: one of :data:`BLOCKING_TYPES`.
        node_id: the node it is attached to.
        sequence_id: that node's ``sequenceId``.
        parameters: its ``actionParameters`` as ``(key, value)`` pairs.
    """

    action_id: str
    action_type: str
    blocking_type: str
    node_id: str
    sequence_id: int
    parameters: tuple[tuple[str, Any], ...] = ()

    def parameter(self, key: str) -> Any:
        """The value of parameter ``key`` (None: not given)."""
        return next((v for k, v in self.parameters if k == key), None)


class Effects(Protocol):
    """What the actions do to the vehicle (``agv_app.vda5050.handling``)."""

    def begin(self, action: OrderAction, now: float) -> float | VdaError:
        """Start ``action``: the seconds it runs (0: done at once), or why it fails."""
        ...

    def complete(self, action: OrderAction, now: float) -> str | VdaError:
        """End ``action``, which ran its time: its result, or why it failed."""
        ...


@dataclass(slots=True)
class ActionRecord:
    """An order action and where it stands.

    Attributes:
        action: the action.
        status: its ``actionStatus``.
        result: its ``actionResult`` once it ended.
        due: while running, when it ends.
        left: while paused, the seconds it still has to run.
    """

    action: OrderAction
    status: str = "WAITING"
    result: str = ""
    due: float | None = None
    left: float = 0.0

    def to_json(self) -> dict[str, Any]:
        """The ``actionState`` object."""
        out: dict[str, Any] = {
            "actionId": self.action.action_id,
            "actionType": self.action.action_type,
            "actionStatus": self.status,
        }
        if self.result:
            out["actionResult"] = self.result
        return out


class ActionBook:
    """The ``actionStates`` of an order, and the queue of the ones triggered (see the
    module doc).

    Args:
        effects: what the actions do.
    """

    def __init__(self, effects: Effects) -> None:
        self.effects = effects
        self.records: dict[str, ActionRecord] = {}
        """Every action of the order, by ``actionId``, in the order received."""
        self.paused = False
        self._queue: list[ActionRecord] = []
        self._errors: list[VdaError] = []

    # -- reading --------------------------------------------------------------------------

    @property
    def idle(self) -> bool:
        """True when every action has ended (VDA 5050 3.0 section 6.6.8)."""
        return all(r.status in ENDED for r in self.records.values())

    @property
    def blocks_driving(self) -> bool:
        """True while a 'SOFT' or 'HARD' action is in the queue: the vehicle stands."""
        return any(r.action.blocking_type in _STOPPING for r in self._queue)

    def running(self, action_type: str) -> bool:
        """True while an action of ``action_type`` runs (or is paused)."""
        return any(
            r.action.action_type == action_type and r.status in ("RUNNING", "PAUSED")
            for r in self._queue
        )

    def at(self, sequence_id: int) -> list[ActionRecord]:
        """The actions of the node with ``sequence_id``."""
        return [r for r in self.records.values() if r.action.sequence_id == sequence_id]

    def to_json(self) -> list[dict[str, Any]]:
        """``actionStates``."""
        return [r.to_json() for r in self.records.values()]

    def take_errors(self) -> list[VdaError]:
        """The errors of actions that failed since the last call."""
        out, self._errors = self._errors, []
        return out

    # -- the order ------------------------------------------------------------------------

    def replace(self, actions: list[OrderAction]) -> None:
        """A new order: its actions, every one 'WAITING'."""
        self.records = {a.action_id: ActionRecord(a) for a in actions}
        self._queue = []

    def update(self, stitch_sequence_id: int, actions: list[OrderAction]) -> None:
        """An order update stitched at ``stitch_sequence_id``: the actions of the old
        horizon go (6.6.9.1), the update's new ones come; those of the stitching node
        are known already and are not carried out again (6.1.2)."""
        self.records = {
            i: r
            for i, r in self.records.items()
            if r.action.sequence_id <= stitch_sequence_id or r.status != "WAITING"
        }
        for action in actions:
            if action.sequence_id > stitch_sequence_id and action.action_id not in self.records:
                self.records[action.action_id] = ActionRecord(action)

    def trigger(self, sequence_id: int, now: float) -> bool:
        """The node with ``sequence_id`` is traversed: its actions join the queue.

        Returns:
            True if any action changed its status.
        """
        for record in self.at(sequence_id):
            if record.status == "WAITING" and record not in self._queue:
                self._queue.append(record)
        return self.advance(now)

    def advance(self, now: float) -> bool:
        """End the running actions whose time is up, start those that may start.

        Returns:
            True if any action changed its status.
        """
        changed = False
        for record in list(self._queue):
            if record.status == "RUNNING" and record.due is not None and now >= record.due:
                self._complete(record, now)
                changed = True
        self._queue = [r for r in self._queue if r.status not in ENDED]
        if self.paused:
            return changed
        while True:
            started = self._start_next(now)
            if started is None:
                return changed
            changed = True

    def _start_next(self, now: float) -> ActionRecord | None:
        """Start the first waiting action of the queue that may start now (None: none)."""
        active = [r for r in self._queue if r.status != "WAITING"]
        if any(r.action.blocking_type in _ALONE for r in active):
            return None
        for record in self._queue:
            if record.status != "WAITING":
                continue
            if record.action.blocking_type in _ALONE and active:
                return None
            self._begin(record, now)
            return record
        return None

    def _begin(self, record: ActionRecord, now: float) -> None:
        outcome = self.effects.begin(record.action, now)
        if isinstance(outcome, VdaError):
            self._fail(record, outcome)
        elif outcome <= 0.0:
            self._complete(record, now)
        else:
            record.status, record.due = "RUNNING", now + outcome

    def _complete(self, record: ActionRecord, now: float) -> None:
        outcome = self.effects.complete(record.action, now)
        record.due = None
        if isinstance(outcome, VdaError):
            self._fail(record, outcome)
        else:
            record.status, record.result = "FINISHED", outcome
        if record.status in ENDED and record in self._queue:
            self._queue.remove(record)

    def _fail(self, record: ActionRecord, error: VdaError) -> None:
        record.status, record.due = "FAILED", None
        if record in self._queue:
            self._queue.remove(record)
        self._errors.append(error)

    # -- instant actions ------------------------------------------------------------------

    def pause(self, now: float) -> bool:
        """``startPause``: pause the running actions that allow it; start none.

        Returns:
            True if any action changed its status.
        """
        self.paused = True
        changed = False
        for record in self._queue:
            spec = CATALOGUE.get(record.action.action_type)
            if record.status == "RUNNING" and spec is not None and spec.pause_allowed:
                assert record.due is not None
                record.status, record.left, record.due = "PAUSED", max(0.0, record.due - now), None
                changed = True
        return changed

    def resume(self, now: float) -> bool:
        """``stopPause``: the paused actions run on for their time left.

        Returns:
            True if any action changed its status.
        """
        self.paused = False
        changed = False
        for record in self._queue:
            if record.status == "PAUSED":
                record.status, record.due = "RUNNING", now + record.left
                changed = True
        return self.advance(now) or changed

    def cancel(self) -> bool:
        """``cancelOrder``: fail what has not started and what may stop while running.

        Returns:
            True once no action of the order runs any more.
        """
        for record in self.records.values():
            spec = CATALOGUE.get(record.action.action_type)
            stoppable = spec is None or spec.cancel_allowed
            if record.status == "WAITING" or (record.status not in ENDED and stoppable):
                record.status, record.due = "FAILED", None
        self._queue = [r for r in self._queue if r.status not in ENDED]
        return self.idle
