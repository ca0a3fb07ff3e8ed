"""Vehicles that only take part in the task auction: they bid while free, take what they
win, stand at its pick station at once, and deliver or hand back when told."""

from __future__ import annotations

from typing import Any

from agv_app.protocol import AGV_KIND
from agv_app.tasks.auction import Bidder, TaskSpec
from objectplaces import RoleActivator


class FakeAgv:
    """One such vehicle on ``node``, standing at ``position``.

    ``held`` is what it carries, oldest first; ``delivered`` every task it delivered.
    """

    def __init__(self, node: RoleActivator, position: tuple[float, float]) -> None:
        self.node = node
        self.held: list[TaskSpec] = []
        self.delivered: list[str] = []
        node.update_node_property("kind", AGV_KIND)
        node.update_node_property("position", position)
        self._publish(task=None, last_done=None, returned=None)
        node.set_participant_factory("bidder", lambda: Bidder(self))

    @property
    def node_id(self) -> str:
        return self.node.node_id

    def bid_for(self, task: TaskSpec) -> float | None:
        return None if self.held else 1.0

    def take(self, task: TaskSpec) -> None:
        self.held.append(task)
        self._publish(task=task.id, reached_pick=task.id)

    def deliver(self) -> str:
        """Deliver the oldest task held; its id."""
        task = self.held.pop(0)
        self.delivered.append(task.id)
        self._publish(last_done=task.id, task=self.held[0].id if self.held else None)
        return task.id

    def hand_back(self) -> str:
        """Give the oldest task held back, undone; its id."""
        task = self.held.pop(0)
        self._publish(returned=task.id, task=self.held[0].id if self.held else None)
        return task.id

    def forget(self) -> None:
        """Lose every task held, as a restarted vehicle process does."""
        self.held.clear()
        self._publish(task=None, last_done=None, returned=None)

    def _publish(self, **props: Any) -> None:
        for name, value in props.items():
            self.node.update_node_property(name, value)
        self.node.update_node_property("status", "busy" if self.held else "idle")
