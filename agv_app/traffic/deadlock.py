"""Deadlock avoidance: where along its route an AGV may come to rest.

An AGV drives only over area it has locked, and every lock request it makes ends
where the AGV may stop. Two AGVs meeting head-on on a bidirectional path can only
deadlock if each rests with its hull on that path, so requests are cut so that this
never happens:

* a request that enters a bidirectional segment covers the path up to the next
  passing place (``Layout.passing_extent``), and further, until the hull is clear of
  every bidirectional segment of the route by ``clearance`` (half a hull length plus
  the radius another AGV sweeps when it turns at the segment's mouth);
* it starts where the hull is clear of that segment's mouth by the same margin.

A passing place where the hull still covers the lane (a junction in the middle of a
two-way main lane) does not count as a resting place: an AGV waiting there blocks the
oncoming one exactly as it would inside the segment.

Why head-on AGVs never deadlock: a request that enters a bidirectional run reaches a
clear resting place beyond it, so the whole passage through the run is one request.
Locks are mutually exclusive, so at most one of two oncoming AGVs holds the passage;
it never waits inside the run (its lock reaches past it) and drives out, releasing
the run behind it. The other one waits clear of the mouth, where the first one's
passage does not need its area, and gets the run once the first one has left.

Yielding. The argument needs every waiting AGV to wait at a resting place, but a
route may *start* where the AGV may not rest: a dead-end dock at the end of a two-way
run, where it dwelt to load or unload. Two AGVs standing at the two docks of one run,
each bound for the other's dock, each request the whole passage including the other's
hull, and wait forever. So an AGV that has not left the start of its route, stands in
a no-rest zone of it and has waited ``AgvConfig.yield_after`` for its first lock
because of someone's lock backs off to a waiting place (its home: a parking spot at a
dead end or off every two-way lane), then goes on from there, which is a resting
place. See docs/traffic.md for the whole argument and its limits.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from agv_app.layout.elements import Route
from agv_app.layout.graph import Layout

__all__ = ["DEFAULT_CLEARANCE_M", "StopPlan", "clearance_for"]


def clearance_for(length_m: float, width_m: float, *, margin_m: float = 0.15) -> float:
    """Distance an AGV's centre keeps from a bidirectional run it waits to enter.

    Its front (half a length ahead) must stay out of the circle another AGV of the
    same size sweeps while turning on the spot at the run's mouth.
    """
    return length_m / 2 + math.hypot(length_m / 2, width_m / 2) + margin_m


DEFAULT_CLEARANCE_M = clearance_for(2.0, 1.0)
"""The clearance for the demo's 2 m x 1 m vehicles."""


@dataclass(frozen=True, slots=True)
class StopPlan:
    """The resting places of one route.

    Attributes:
        length: route length, metres.
        zones: merged open intervals ``(lo, hi)`` of arc length where the AGV must not
            rest (the route end is always allowed).
    """

    length: float
    zones: tuple[tuple[float, float], ...]

    @classmethod
    def for_route(cls, layout: Layout, route: Route, *, clearance_m: float) -> StopPlan:
        """Compute the no-rest zones of ``route`` on ``layout``."""
        raw: list[tuple[float, float]] = []
        for i, seg_id in enumerate(route.segments):
            if not layout.segment(seg_id).bidirectional:
                continue
            extent = layout.passing_extent(route, i)
            lo = route.offsets[i] - clearance_m
            hi = max(route.offsets[i + 1], extent.s) + clearance_m
            raw.append((lo, hi))
        raw.sort()
        merged: list[tuple[float, float]] = []
        for lo, hi in raw:
            if merged and lo <= merged[-1][1]:
                merged[-1] = (merged[-1][0], max(merged[-1][1], hi))
            else:
                merged.append((lo, hi))
        return cls(route.length, tuple(merged))

    def may_rest(self, s: float) -> bool:
        """True if the AGV may come to rest with its centre at arc length ``s``."""
        if s >= self.length:
            return True
        return not any(lo < s < hi for lo, hi in self.zones)

    def next_stop(self, from_s: float, advance_m: float) -> float:
        """The first resting place at or beyond ``from_s + advance_m`` (capped at the end).

        A stop that would leave less than ``advance_m / 4`` to the route end is moved to
        the end, so the last request does not cover a sliver.
        """
        target = min(from_s + advance_m, self.length)
        for lo, hi in self.zones:
            if lo < target < hi:
                target = hi
        if target >= self.length - advance_m / 4:
            return self.length
        return target
