"""Admission that follows the floor: how many tasks the desk lets onto it at once.

A floor carries only so many moving AGVs; past that, more tasks at once fill its lanes
and every AGV waits longer than it drives (docs/fleet.md, "More AGVs than the floor
carries"). How many depends on the layout, the task stream and the fleet, so a fixed
limit is right for one of them at best. :class:`AdaptiveLimit` finds it the way a
congestion window does (additive increase, multiplicative decrease), from what the
fleet shows:

* a **long wait** (an AGV that wants to move has waited over a minute,
  :data:`~agv_app.fleet.stalls.LONG_WAIT_S`) is the sign the lanes are full: the limit
  drops to three quarters of the tasks on the floor, at most once per ``hold_s`` (one
  jam shows as several long waits together);
* a **delivery** while the limit holds tasks back, and no cut in the last ``hold_s``,
  raises the limit by one: the floor carried what it had.

The limit starts at what the floor's lanes carry (:func:`carried_tasks`)
and never drops below ``floor``: a floor with tasks always has some on it.
"""

from __future__ import annotations

import math

from agv_app.layout.graph import Layout
from agv_app.traffic.deadlock import followable_segments

__all__ = ["CROWDED", "LANE_M_PER_OPEN_TASK", "AdaptiveLimit", "carried_tasks", "limit_for"]

CROWDED = "crowded"
"""The fleets' default limit on open tasks: the automatic one (``"auto"``) for a fleet
with more AGVs than its floor carries tasks (:func:`carried_tasks`), none otherwise. A
fleet that small never puts more AGVs on the lanes than they carry, and a limit would
only hold tasks back from the stations' queues; a larger one can fill a one-way loop
(docs/fleet.md, "More AGVs than the floor carries")."""

LANE_M_PER_OPEN_TASK = 20.0
"""Metres of lane a floor needs for each task on it at once, about, once its lanes
fill: measured, not derived (docs/fleet.md, "More AGVs than the floor carries"). The
demo warehouse (434 m of one-way lane) delivered most with about 20 tasks on the floor,
the generated warehouse for 100 AGVs (304 m) with about 15. A floor whose lanes do not
fill (long tasks on the long loop) carries more."""


def carried_tasks(layout: Layout) -> int | None:
    """About how many tasks ``layout`` carries at once: its lanes (one-way segments and
    two-way ones that routes drive through) over :data:`LANE_M_PER_OPEN_TASK`; None
    for a floor without such lanes (every two-way run ends in a dead end)."""
    through = followable_segments(layout)
    lanes = sum(
        layout.segment_length(seg.id)
        for seg in layout.segments.values()
        if not seg.bidirectional or seg.id in through
    )
    carried = math.floor(lanes / LANE_M_PER_OPEN_TASK)
    return carried if carried >= 1 else None


def limit_for(choice: int | str | None, layout: Layout, agvs: int) -> int | str | None:
    """The limit on open tasks ``agvs`` AGVs on ``layout`` run with when ``choice`` is
    asked for: :data:`CROWDED` is ``"auto"`` or None by the fleet's size; any other
    choice stands."""
    if choice != CROWDED:
        return choice
    carried = carried_tasks(layout)
    return "auto" if carried is not None and agvs > carried else None


class AdaptiveLimit:
    """Tasks on the floor at once, at most, raised and cut by what the fleet shows.

    Args:
        start: the limit at first.
        floor: the lowest limit.
        hold_s: seconds after a cut in which neither another cut nor a raise happens.
        decrease: the share of the tasks on the floor a cut keeps.

    Raises:
        ValueError: ``start`` or ``floor`` below 1, ``hold_s`` negative, or
            ``decrease`` not in (0, 1).
    """

    def __init__(
        self, start: int, *, floor: int = 2, hold_s: float = 60.0, decrease: float = 0.75
    ) -> None:
        if floor < 1 or start < 1:
            raise ValueError(f"start and floor must be at least 1, got {start!r} and {floor!r}")
        if hold_s < 0:
            raise ValueError(f"hold_s must be 0 or more, got {hold_s!r}")
        if not 0.0 < decrease < 1.0:
            raise ValueError(f"decrease must be in (0, 1), got {decrease!r}")
        self.floor = floor
        self.hold_s = hold_s
        self.decrease = decrease
        self.limit = max(start, floor)
        """Tasks the desk may have on the floor now."""
        self.cuts = 0
        """Cuts so far."""
        self.lowest = self.limit
        """The lowest limit so far."""
        self._cut_at = -math.inf

    def long_wait(self, on_floor: int, now: float) -> None:
        """An AGV has waited over a minute to move, with ``on_floor`` tasks open: cut
        the limit to ``decrease`` of them (not within ``hold_s`` of the last cut)."""
        if now < self._cut_at + self.hold_s:
            return
        cut = max(self.floor, math.floor(self.decrease * min(on_floor, self.limit)))
        if cut < self.limit:
            self.limit = cut
            self.cuts += 1
            self.lowest = min(self.lowest, cut)
        self._cut_at = now

    def delivered(self, *, held_back: bool, now: float) -> None:
        """A task was delivered; ``held_back``: tasks wait at the desk for room. Raise
        the limit by one then, unless a cut came within ``hold_s``."""
        if held_back and now >= self._cut_at + self.hold_s:
            self.limit += 1
