"""Who holds which task, and when a vehicle has handed one back: the rule behind "none
twice".

A task awarded to a vehicle is auctioned again only once that vehicle hands it back.
The task desk feeds :class:`CustodyMachine` what its base node hears of the vehicles
and acts on what the machine concludes; the machine reads no clock (``now`` comes in)
and touches no node. A vehicle that holds a task either delivers it or hands it back:

* **delivered**: its ``last_done`` names the task. A vehicle carries its tasks in the
  order they were awarded, and is awarded a task while it holds another only as it
  dwells at that one's drop station; so the task it named when this one was awarded is
  delivered too, and so on back (a control that was down while the vehicle reported
  one of them hears only the last: properties keep the newest value, not the history).
  Tasks restored after a restart count as awarded in their order, the later after the
  earlier ones; a task the vehicle did not name when the next was awarded (it had
  forgotten it, or never heard of it) is not taken as delivered.
* **returned**: its ``returned`` names the task, and its ``task`` does not (a stale
  ``returned`` from before a new award of the same task means nothing);
* **unnamed**: its ``task`` has not named the task for ``grace`` seconds: from the award
  (or from the restart of a control that restores it) until the vehicle is first heard
  naming it, or since it was last heard naming another task or none. A vehicle whose
  process restarted has forgotten the task; one never heard again after a control's
  restart is gone. The grace outlasts the dwell at a drop station, during which a
  vehicle names the next task it took and reports this one done only as the dwell ends.

A vehicle that departs (its node fails) is the station's to handle, as ever
(:mod:`agv_app.tasks.station`): it gives the task back unless the vehicle is heard
again carrying it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

__all__ = [
    "DEFAULT_HAND_BACK_AFTER",
    "CustodyMachine",
    "Delivered",
    "HandBackReason",
    "HandedBack",
    "Verdict",
]

DEFAULT_HAND_BACK_AFTER = 30.0
"""Seconds a vehicle may hold a task without naming it (``CustodyMachine``'s ``grace``):
several times a dwell at a station, and past the time a vehicle's properties take to
reach a restarted control."""

HandBackReason = Literal["returned", "unnamed"]
"""Why a task came back: the vehicle said so, or it has not named the task for the grace."""


@dataclass(frozen=True, slots=True)
class Delivered:
    """The vehicle delivered the task."""

    task_id: str
    vehicle: str


@dataclass(frozen=True, slots=True)
class HandedBack:
    """The vehicle no longer holds the task: it may be awarded again."""

    task_id: str
    vehicle: str
    reason: HandBackReason


Verdict = Delivered | HandedBack
"""What the machine concludes about a held task."""


@dataclass(slots=True)
class _Holding:
    vehicle: str
    unnamed_since: float | None
    """Since when the vehicle has not named the task (None: it names it now)."""
    after: tuple[str, ...]
    """The tasks of the vehicle delivered before this one, once this one is."""
    restored: bool


class CustodyMachine:
    """The tasks vehicles hold, in award order, and the rule that ends each holding.

    Args:
        grace: seconds a vehicle may hold a task without naming it.

    Raises:
        ValueError: ``grace`` is not positive.
    """

    def __init__(self, *, grace: float = DEFAULT_HAND_BACK_AFTER) -> None:
        if not grace > 0:
            raise ValueError(f"grace must be a positive number of seconds, got {grace!r}")
        self.grace = grace
        self._held: dict[str, _Holding] = {}
        """Task id -> holding, oldest award first."""
        self._naming: dict[str, str | None] = {}
        """What each vehicle heard names as its task, by vehicle id."""

    def holder(self, task_id: str) -> str | None:
        """The vehicle that holds ``task_id`` (None: none does, as far as the machine knows)."""
        holding = self._held.get(task_id)
        return None if holding is None else holding.vehicle

    def held(self) -> list[str]:
        """The held tasks' ids, oldest award first."""
        return list(self._held)

    def hold(self, task_id: str, vehicle: str, *, now: float, restored: bool = False) -> None:
        """``task_id`` was awarded to ``vehicle`` at ``now``, or ``restored`` as held by it
        (restore a vehicle's tasks in the order they were awarded)."""
        self._held.pop(task_id, None)  # a new award is the newest
        after = tuple(
            t
            for t, h in self._held.items()
            if h.vehicle == vehicle and (h.restored if restored else h.unnamed_since is None)
        )
        named = self._naming.get(vehicle) == task_id
        self._held[task_id] = _Holding(vehicle, None if named else now, after, restored)

    def release(self, task_id: str) -> bool:
        """``task_id`` is no longer held (finished or returned elsewhere); False if it was not."""
        return self._held.pop(task_id, None) is not None

    def named(self, vehicle: str, task: object, *, now: float) -> None:
        """``vehicle``'s ``task`` property is ``task`` (a task id, or None)."""
        naming = task if isinstance(task, str) else None
        self._naming[vehicle] = naming
        for task_id, holding in self._held.items():
            if holding.vehicle != vehicle:
                continue
            if task_id == naming:
                holding.unnamed_since = None
            elif holding.unnamed_since is None:
                holding.unnamed_since = now

    def done(self, vehicle: str, task: object) -> list[Delivered]:
        """``vehicle``'s ``last_done`` became ``task``: it is delivered, and the tasks the
        vehicle carried before it (see the module docstring), oldest first; none if the
        vehicle holds no such task."""
        if not isinstance(task, str):
            return []
        ended: set[str] = set()
        todo = [task]
        while todo:
            task_id = todo.pop()
            holding = self._held.get(task_id)
            if task_id in ended or holding is None or holding.vehicle != vehicle:
                continue
            ended.add(task_id)
            todo.extend(holding.after)
        out = [Delivered(t, vehicle) for t in self._held if t in ended]
        for t in ended:
            del self._held[t]
        return out

    def returned(self, vehicle: str, task: object) -> list[HandedBack]:
        """``vehicle``'s ``returned`` became ``task``: handed back, unless the vehicle
        names it as its task (then the ``returned`` is older than its award)."""
        if not isinstance(task, str):
            return []
        holding = self._held.get(task)
        if holding is None or holding.vehicle != vehicle or self._naming.get(vehicle) == task:
            return []
        del self._held[task]
        return [HandedBack(task, vehicle, "returned")]

    def departed(self, vehicle: str) -> None:
        """``vehicle``'s node failed or left: what it named is unknown from now on (its
        tasks are the station's to give back)."""
        self._naming.pop(vehicle, None)

    def tick(self, *, now: float) -> list[HandedBack]:
        """The tasks not named for ``grace`` seconds by ``now``: handed back, oldest award
        first."""
        expired = [
            task_id
            for task_id, holding in self._held.items()
            if holding.unnamed_since is not None and now - holding.unnamed_since >= self.grace
        ]
        out = []
        for task_id in expired:
            holding = self._held.pop(task_id)
            out.append(HandedBack(task_id, holding.vehicle, "unnamed"))
        return out

    def next_deadline(self) -> float | None:
        """When ``tick`` may next hand a task back (None: no task is unnamed)."""
        times = [h.unnamed_since for h in self._held.values() if h.unnamed_since is not None]
        return min(times) + self.grace if times else None
