"""A mesh fleet's automatic tasks: none until the observer hears every AGV, then
``start_tasks`` at once and one at each arrival of a Poisson stream
(:class:`~agv_app.tasks.load.TaskArrivals`).
"""

from __future__ import annotations

from collections.abc import Callable, Collection

from agv_app.tasks.desk import TaskDesk
from agv_app.tasks.load import TaskArrivals

__all__ = ["AutoTasks"]


class AutoTasks:
    """Creates a mesh fleet's automatic tasks as its clock goes (:meth:`tick`).

    Args:
        desk: where the tasks are created, at random pick stations.
        arrivals: when new tasks come (None: never; ``tick`` is then not called).
        start_tasks: tasks created at once when every AGV is first heard.
        agvs: how many AGVs to hear first.
        heard: the AGVs the observer hears.
    """

    def __init__(
        self,
        desk: TaskDesk,
        arrivals: TaskArrivals | None,
        *,
        start_tasks: int,
        agvs: int,
        heard: Callable[[], Collection[str]],
    ) -> None:
        self.desk = desk
        self.arrivals = arrivals
        self.start_tasks = start_tasks
        self.agvs = agvs
        self.heard = heard
        self.next_at: float | None = None
        """When the next task is due (None: not every AGV heard yet)."""

    def tick(self, now: float) -> None:
        """Create the tasks due at ``now``."""
        assert self.arrivals is not None
        if self.next_at is None:
            if len(self.heard()) < self.agvs:
                return
            self.next_at = now
            for _ in range(self.start_tasks):
                self.desk.create_random()
        if now >= self.next_at:
            self.desk.create_random()
            self.next_at = self.arrivals.next_after(now)
