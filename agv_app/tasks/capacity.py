"""What a floor carries: the most tasks per second its shared parts let through.

A fleet's own capacity is its vehicles over the mean task time (``N / T``,
:mod:`agv_app.tasks.load`); a floor has one too, whatever the fleet. Where two-way
segments join into a stretch with no other way round (a lane between two areas, the
arms of a crossing, a door between halls), an AGV driving through holds the whole
stretch, and one coming the other way waits for it; a station serves one AGV at a
time; and a station that calls one AGV at a time hands out no task while its last
winner is on the way or a load is bound for it. Each such **shared part** carries one
AGV at a time, so it lets through at most one task per the seconds an average task
keeps it busy, weighted over the tasks as
:func:`~agv_app.tasks.free_flow.mean_task_seconds` weights them:

* ``segment:<id>``, ``point:<id>``: a segment of a two-way stretch and every point on
  it (where two stretches cross, both), for one pass over the whole stretch on the
  approach to the pick and on the carry to the drop;
* ``point:<id>`` of a station, besides, for a dwell at the pick and one at the drop;
* ``station:<id>``, with :attr:`FloorRules.one_at_a_time`, for the approach of the
  AGV it called, and with :attr:`FloorRules.wait_for_drop` too, for the carry of a
  load bound for it.

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

__all__ = [
    "FREE_FLOW_RULES",
    "FloorCapacity",
    "FloorRules",
    "floor_capacity",
    "shared_part_seconds",
]


@dataclass(frozen=True, slots=True)
class FloorRules:
    """How a fleet uses its floor, as far as what the floor carries goes.

    Attributes:
        hold_s: seconds one pass holds a drive of so many metres (None: driving it at
            top speed; a fleet: from a standstill, with the handover,
            :func:`~agv_app.tasks.load.standstill_pass`).
        one_at_a_time: stations call one AGV at a time: a station is busy while the
            AGV it called drives to it (:class:`~agv_app.tasks.station.Station`).
        wait_for_drop: with ``one_at_a_time``, a station is busy while a load bound
            for it is carried there too.
    """

    hold_s: Callable[[float], float] | None = None
    one_at_a_time: bool = False
    wait_for_drop: bool = False


FREE_FLOW_RULES = FloorRules()
"""Every drive at top speed, no station rule: the floor with nothing but its shape."""


def shared_part_seconds(
    timer: FreeFlowTimer,
    picks: Sequence[str],
    drops: Sequence[str],
    rules: FloorRules = FREE_FLOW_RULES,
) -> dict[str, float]:
    """Seconds an average task keeps each shared part of the floor busy, by part
    (module docstring). A floor of one-way lanes with no dwell and no station rule has
    none."""
    layout = timer.layout
    hold = rules.hold_s or (lambda metres: metres / timer.speed_m_s)
    busy: defaultdict[str, float] = defaultdict(float)

    def drive(start: str, end: str, weight: float, calls: str | None) -> None:
        if start == end:
            return
        try:
            route = layout.route(start, end)
        except NoRouteError:
            return
        if calls is not None:
            busy[f"station:{calls}"] += weight * hold(route.length)
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

    point_of = {s: layout.station(s).point for s in {*picks, *drops}}
    pairs = [(p, d) for p in picks for d in drops if d != p]
    carried_to = rules.one_at_a_time and rules.wait_for_drop
    for p, d in pairs:
        drive(point_of[p], point_of[d], 1.0 / len(pairs), d if carried_to else None)
    approach = 1.0 / (len(drops) * len(picks))
    for q in drops:
        for p in picks:
            drive(point_of[q], point_of[p], approach, p if rules.one_at_a_time else None)
    if timer.dwell_s > 0:
        for p in picks:
            busy[f"point:{point_of[p]}"] += timer.dwell_s / len(picks)
        for d in drops:
            busy[f"point:{point_of[d]}"] += timer.dwell_s / len(drops)
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
    rules: FloorRules = FREE_FLOW_RULES,
) -> FloorCapacity:
    """The most tasks the floor carries: one per the seconds an average task keeps its
    busiest shared part busy (module docstring)."""
    busy = shared_part_seconds(timer, picks, drops, rules)
    if not busy:
        return FloorCapacity(None, 0.0)
    part = max(sorted(busy), key=busy.__getitem__)
    return FloorCapacity(part, busy[part])
