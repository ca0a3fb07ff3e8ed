"""Free-flow task times: what a task takes with its routes driven at full speed, no waiting.

A task keeps its vehicle busy from the award to the delivery: the drive to the pick
station (from where the vehicle stands, usually its last drop), a dwell there, the drive
to the drop station and a dwell there. Driven at top speed along the shortest routes,
with no acceleration and no waiting for locks, that is the task's *free-flow* time: no
real run does better.

Two uses: :func:`mean_task_seconds` estimates the mean over the tasks a layout's
stations make (for the task rate that gives a target load, see
:mod:`agv_app.tasks.load`); :class:`FreeFlowBound` replays the tasks a run actually
created on ``N`` vehicles working back to back at free-flow times and counts how many
they would have finished: what the run could have delivered without traffic. It is an
estimate of that ceiling rather than a strict bound: the replay gives each task to the
vehicle free first, the task auction to the nearest bidder, which can do better.
"""

from __future__ import annotations

import heapq
import math
from collections import OrderedDict
from collections.abc import Sequence
from dataclasses import dataclass

from agv_app.layout.graph import Layout
from agv_app.tasks.auction import TaskSpec

__all__ = ["FreeFlowBound", "FreeFlowTimer", "mean_task_seconds"]


@dataclass(frozen=True, slots=True)
class FreeFlowTimer:
    """Free-flow times on one layout.

    Attributes:
        layout: the floor plan.
        speed_m_s: the vehicles' top speed.
        dwell_s: seconds at a pick or drop station.
    """

    layout: Layout
    speed_m_s: float
    dwell_s: float

    def __post_init__(self) -> None:
        if not (self.speed_m_s > 0 and math.isfinite(self.speed_m_s)):
            raise ValueError(f"speed must be a positive number, got {self.speed_m_s!r}")
        if not (self.dwell_s >= 0 and math.isfinite(self.dwell_s)):
            raise ValueError(f"dwell must be 0 or more seconds, got {self.dwell_s!r}")

    def drive_seconds(self, start: str, end: str) -> float:
        """Seconds from point ``start`` to point ``end`` at top speed (inf: no route)."""
        return self.layout.distance(start, end) / self.speed_m_s

    def task_seconds(self, start: str, task: TaskSpec) -> float:
        """Seconds of ``task`` for a vehicle at point ``start``: to the pick, dwell, to the
        drop, dwell."""
        pick = self.layout.station(task.pick).point
        drop = self.layout.station(task.drop).point
        return self.drive_seconds(start, pick) + self.drive_seconds(pick, drop) + 2 * self.dwell_s


def mean_task_seconds(timer: FreeFlowTimer, picks: Sequence[str], drops: Sequence[str]) -> float:
    """Mean free-flow time of a task made as the task desk makes them.

    The pick station is any of ``picks`` and the drop any of ``drops`` but the pick,
    each equally likely; the vehicle comes from any of ``drops`` (where a busy vehicle
    finished its last task), equally likely.

    Raises:
        ValueError: no pick station, or no drop station apart from it, or a station
            that cannot reach another.
    """
    layout = timer.layout
    pairs = [(p, d) for p in picks for d in drops if d != p]
    if not pairs:
        raise ValueError(
            f"layout {layout.name!r} has no pick and drop stations to make tasks of "
            f"(pick: {list(picks)!r}, drop: {list(drops)!r})"
        )
    point = {s: layout.station(s).point for s in {*picks, *drops}}
    carry = sum(timer.drive_seconds(point[p], point[d]) for p, d in pairs) / len(pairs)
    approach = sum(timer.drive_seconds(point[q], point[p]) for q in drops for p in picks) / (
        len(drops) * len(picks)
    )
    total = approach + carry + 2 * timer.dwell_s
    if math.isinf(total):
        raise ValueError(f"layout {layout.name!r} has stations that cannot reach each other")
    return total


class FreeFlowBound:
    """The tasks of a run replayed on its vehicles at free-flow times.

    Every created task goes, in creation order, to the vehicle that is free first; it
    starts when both it exists and that vehicle is free, and takes its free-flow time
    from where that vehicle is (its home at first, then its last drop). Memory: one
    entry per vehicle, plus the finish times still ahead of the last ``completed`` call.

    Each task's free-flow lead time (from its creation to its delivery in the replay) is
    kept for the last ``keep`` tasks (:meth:`lead_seconds`): what the task takes in a run
    without traffic, its wait for a free vehicle included.

    Args:
        timer: free-flow times on the fleet's layout.
        homes: each vehicle's starting point.
        keep: how many tasks' lead times to keep.

    Raises:
        ValueError: no vehicles.
    """

    def __init__(self, timer: FreeFlowTimer, homes: Sequence[str], *, keep: int = 1000) -> None:
        if not homes:
            raise ValueError("a free-flow bound needs at least one vehicle")
        self.timer = timer
        self._free: list[tuple[float, int, str]] = [(0.0, i, h) for i, h in enumerate(homes)]
        self._ahead: list[float] = []
        self._finished = 0
        self._keep = keep
        self._lead: OrderedDict[str, float] = OrderedDict()

    def add(self, task: TaskSpec, now: float) -> None:
        """A task was created at ``now``."""
        free_at, index, where = heapq.heappop(self._free)
        seconds = self.timer.task_seconds(where, task)
        if not math.isfinite(seconds):  # no route: no vehicle could do it either
            heapq.heappush(self._free, (free_at, index, where))
            return
        finish = max(free_at, now) + seconds
        heapq.heappush(self._free, (finish, index, self.timer.layout.station(task.drop).point))
        heapq.heappush(self._ahead, finish)
        self._lead[task.id] = finish - now
        if len(self._lead) > self._keep:
            self._lead.popitem(last=False)

    def lead_seconds(self, task_id: str) -> float | None:
        """Seconds from the creation of ``task_id`` to its delivery in the replay (None:
        not among the last ``keep`` tasks, or no vehicle could do it)."""
        return self._lead.get(task_id)

    def completed(self, now: float) -> int:
        """Tasks the free-flow replay has finished by ``now`` (call with ``now`` not
        going back)."""
        while self._ahead and self._ahead[0] <= now:
            heapq.heappop(self._ahead)
            self._finished += 1
        return self._finished

    def per_hour(self, now: float) -> float:
        """Free-flow tasks per hour: ``completed(now)`` over the ``now`` seconds run."""
        return self.completed(now) * 3600.0 / now if now > 0 else 0.0
