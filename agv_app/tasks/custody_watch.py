"""What a task desk's base hears of the vehicles that hold tasks, fed to the custody rule.

:class:`CustodyWatch` listens on the desk's base nodes for each vehicle's ``task``,
``last_done`` and ``returned`` and for its node's departure, tells the
:class:`~agv_app.tasks.custody.CustodyMachine`, and has the first base's clock wake it
when a held task may be due back. What the rule concludes (a task delivered, or handed
back) goes to the desk's ``settle``, never from inside a view's update.
"""

from __future__ import annotations

from collections.abc import Callable

from agv_app.tasks.custody import CustodyMachine, Verdict
from objectplaces import RoleActivator

__all__ = ["CustodyWatch"]


class CustodyWatch:
    """Feeds a desk's custody rule from what its base nodes hear, and keeps its timer.

    Args:
        custody: who holds each task handed out.
        clock: the fleet's time, seconds.
        settle: acts on the verdicts of the custody rule (the desk's).
    """

    def __init__(
        self,
        custody: CustodyMachine,
        clock: Callable[[], float],
        settle: Callable[[list[Verdict]], None],
    ) -> None:
        self.custody = custody
        self.clock = clock
        self.settle = settle
        self._heard_on: set[str] = set()
        """The nodes whose views the watch follows."""
        self._node: RoleActivator | None = None
        self._timer_at: float | None = None

    def follow(self, node: RoleActivator) -> None:
        """Hear the vehicles through ``node`` (once per node; the first one keeps the
        timer)."""
        if self._node is None:
            self._node = node
        if node.node_id in self._heard_on:
            return
        self._heard_on.add(node.node_id)
        node.register_node_property_observer(
            lambda vehicle, name, value: self._heard(node, vehicle, name, value),
            names=("task", "last_done", "returned"),
        )
        node.register_node_departure_observer(lambda vehicle, _: self.custody.departed(vehicle))

    def _heard(self, node: RoleActivator, vehicle: str, name: str, value: object) -> None:
        now = self.clock()
        verdicts: list[Verdict] = []
        if name == "task":
            self.custody.named(vehicle, value, now=now)
        elif name == "last_done":
            verdicts.extend(self.custody.done(vehicle, value))
        elif name == "returned":
            # The task it names now, not the one an older update named.
            self.custody.named(vehicle, node.view().get(vehicle, {}).get("task"), now=now)
            verdicts.extend(self.custody.returned(vehicle, value))
        self.arm()
        if verdicts:
            # Not from inside the view's update: the vehicle's other properties may follow.
            node.call_later(0.0, lambda: self.settle(verdicts))

    def arm(self) -> None:
        """Have the base's clock wake the watch when a held task may be due back."""
        node, deadline = self._node, self.custody.next_deadline()
        if node is None or deadline is None:
            return
        if self._timer_at is not None and self._timer_at <= deadline:
            return
        self._timer_at = deadline
        node.call_later(max(0.0, deadline - self.clock()), self._expire)

    def _expire(self) -> None:
        self._timer_at = None
        verdicts: list[Verdict] = list(self.custody.tick(now=self.clock()))
        self.settle(verdicts)
