"""What a floor carries: the most tasks per second its shared stretches let through.

A fleet's own capacity is its vehicles over the mean task time (``N / T``,
:mod:`agv_app.tasks.load`); a floor has one too, whatever the fleet. Where two-way
segments join into a stretch with no other way round (a lane between two areas, the
arms of a crossing, a door between halls), an AGV driving through holds the whole
stretch, and one coming the other way waits for it; and a station serves one AGV at a
time. Each such **shared part** carries one AGV at a time, so it lets through at most
one task per the seconds an average task keeps it busy:

* a segment of a two-way stretch, and every point on the stretch (where two stretches
  cross, both), for one pass over the whole stretch (``hold_s``: at top speed unless
  the caller knows better, e.g. from a standstill and with the handover of the floor
  to the next AGV, as the fleet does), on the approach to the pick and on the carry to
  the drop, weighted as :func:`~agv_app.tasks.free_flow.mean_task_seconds` weights
  them;
* a station's point, besides, for a dwell at the pick and a dwell at the drop.

The busiest part is the floor's bottleneck: :func:`floor_capacity` is one task per its
seconds. Counting each part one AGV at a time is cautious: AGVs that follow each other
the same way through a stretch share it, so a floor carries somewhat more; a load below
one of this rate is below what the floor carries.
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from agv_app.layout.elements import NoRouteError
from agv_app.tasks.free_flow import FreeFlowTimer

__all__ = ["FloorCapacity", "floor_capacity", "shared_part_seconds"]


def shared_part_seconds(
    timer: FreeFlowTimer,
    picks: Sequence[str],
    drops: Sequence[str],
    hold_s: Callable[[float], float] | None = None,
) -> dict[str, float]:
    """Seconds an average task keeps each shared part of the floor busy, by part:
    ``"segment:<id>"`` for a segment of a two-way stretch, ``"point:<id>"`` for a point
    on one or a station's point (module docstring). ``hold_s``: seconds one pass holds
    a stretch of that many metres (None: driving it at top speed). A floor of one-way
    lanes with no dwell has none."""
    layout = timer.layout
    hold = hold_s or (lambda metres: metres / timer.speed_m_s)
    busy: defaultdict[str, float] = defaultdict(float)

    def drive(start: str, end: str, weight: float) -> None:
        if start == end:
            return
        try:
            route = layout.route(start, end)
        except NoRouteError:
            return
        two_way = [layout.segment(s).bidirectional for s in route.segments]
        i = 0
        while i < len(two_way):
            if not two_way[i]:
                i += 1
                continue
            j = i
            while j < len(two_way) and two_way[j]:
                j += 1
            held = weight * hold(route.offsets[j] - route.offsets[i])
            for seg in route.segments[i:j]:
                busy[f"segment:{seg}"] += held
            for point in route.points[i : j + 1]:
                busy[f"point:{point}"] += held
            i = j

    point = {s: layout.station(s).point for s in {*picks, *drops}}
    pairs = [(p, d) for p in picks for d in drops if d != p]
    for p, d in pairs:
        drive(point[p], point[d], 1.0 / len(pairs))
    for q in drops:
        for p in picks:
            drive(point[q], point[p], 1.0 / (len(drops) * len(picks)))
    if timer.dwell_s > 0:
        for p in picks:
            busy[f"point:{point[p]}"] += timer.dwell_s / len(picks)
        for d in drops:
            busy[f"point:{point[d]}"] += timer.dwell_s / len(drops)
    return dict(busy)


@dataclass(frozen=True, slots=True)
class FloorCapacity:
    """The most tasks a floor carries, whatever the fleet, and where it is bound.

    Attributes:
        bottleneck: the busiest shared part (:func:`shared_part_seconds`'s key; None:
            the floor has none).
        busy_s: seconds an average task keeps it busy (0: none).
    """

    bottleneck: str | None
    busy_s: float

    @property
    def tasks_per_second(self) -> float:
        """One task per ``busy_s`` (``inf``: no shared part)."""
        return 1.0 / self.busy_s if self.busy_s > 0 else math.inf

    def __str__(self) -> str:
        if self.bottleneck is None:
            return "no shared part"
        return f"{3600 * self.tasks_per_second:.1f} tasks/h (bottleneck {self.bottleneck})"


def floor_capacity(
    timer: FreeFlowTimer,
    picks: Sequence[str],
    drops: Sequence[str],
    hold_s: Callable[[float], float] | None = None,
) -> FloorCapacity:
    """The most tasks the floor carries: one per the seconds an average task keeps its
    busiest shared part busy (module docstring; ``hold_s`` as for
    :func:`shared_part_seconds`)."""
    busy = shared_part_seconds(timer, picks, drops, hold_s)
    if not busy:
        return FloorCapacity(None, 0.0)
    part = max(sorted(busy), key=busy.__getitem__)
    return FloorCapacity(part, busy[part])
