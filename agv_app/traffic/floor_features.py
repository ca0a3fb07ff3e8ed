"""What a layout's shape says about resting and following, for deadlock avoidance.

Each function reads one feature off a layout (which never changes) and caches it per
layout, for :class:`~agv_app.traffic.deadlock.StopPlan` to turn into no-rest zones:
the two-way runs AGVs may follow each other through, the one-way branches that turn
into a merge or a crossing, the turns off a one-way lane, and the way out of a
destination. docs/traffic.md gives the argument each one serves.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence

from agv_app.geometry import XY
from agv_app.layout.graph import Layout

__all__ = ["followable_segments", "merge_branches", "turn_offs", "way_out"]


# Every AGV of a fleet asks for these at start on the same layout (a layout never
# changes): once per layout, not once per AGV (1.4 and 3.1 ms on the 1,000-AGV floor).
@functools.lru_cache(maxsize=4)
def followable_segments(layout: Layout) -> frozenset[str]:
    """The two-way segments a route may drive *through*, where AGVs may follow each
    other: those of every connected set of two-way segments that one-way segments join
    at two points or more (a way in and a different way out). Two-way spurs and
    lanes that only end in dead ends are not: every route in them stops there."""
    two_way = [s for s in layout.segments.values() if s.bidirectional]
    parent: dict[str, str] = {}

    def root(p: str) -> str:
        while parent.setdefault(p, p) != p:
            parent[p] = parent[parent[p]]
            p = parent[p]
        return p

    for seg in two_way:
        parent[root(seg.start)] = root(seg.end)
    joined: dict[str, set[str]] = {}
    for seg in layout.segments.values():
        if not seg.bidirectional:
            for p in (seg.start, seg.end):
                if p in parent:
                    joined.setdefault(root(p), set()).add(p)
    return frozenset(s.id for s in two_way if len(joined.get(root(s.start), ())) >= 2)


_TURN_RAD = math.radians(20.0)
"""A branch that meets its junction's way on at a wider angle than this turns there."""


def _heading(coords: Sequence[XY], *, at_end: bool) -> float:
    """The heading of a polyline's last piece (``at_end``) or its first one."""
    (x0, y0), (x1, y1) = coords[-2:] if at_end else coords[:2]
    return math.atan2(y1 - y0, x1 - x0)


@functools.lru_cache(maxsize=4)
def merge_branches(layout: Layout) -> frozenset[str]:
    """The one-way segments whose end an AGV must not rest near: those that join
    another way in at a *merge* (a junction that two or more segments enter) by
    turning into the way on, and every one-way segment into a *crossing* (two or more
    one-way segments in and two or more out).

    An AGV at rest on such a junction, or with its front on it, still faces the way
    it came; a vehicle on the lane it joins pulls up behind it into the room its turn
    needs, and each waits for the other for ever. A keep-clear box (a two-way last
    piece, docs/layout-format.md) keeps such an AGV off the junction in the layout;
    these branches get the same no-rest zone from the layout's shape, so a floor drawn
    without boxes (an openTCS plant, a generated warehouse) is safe too. The lane a
    branch joins goes straight on: an AGV resting there waits only on the lane ahead.
    A two-way spur that ends in a dead end is no way on: a branch that goes straight
    into one (an aisle ending on a lane, a parking spur opposite) still turns into
    the lane.
    """
    ways_through = followable_segments(layout)
    entering: dict[str, list[str]] = {}
    one_way_in: dict[str, int] = {}
    leaving: dict[str, list[tuple[str, bool]]] = {}
    for seg in layout.segments.values():
        entering.setdefault(seg.end, []).append(seg.id)
        leaving.setdefault(seg.start, []).append((seg.id, True))
        if seg.bidirectional:
            entering.setdefault(seg.start, []).append(seg.id)
            leaving.setdefault(seg.end, []).append((seg.id, False))
        else:
            one_way_in[seg.end] = one_way_in.get(seg.end, 0) + 1
    branches: set[str] = set()
    for point, ins in entering.items():
        if len(ins) < 2:
            continue
        outs = leaving.get(point, [])
        crossing = (
            one_way_in.get(point, 0) >= 2
            and sum(1 for sid, _ in outs if not layout.segment(sid).bidirectional) >= 2
        )
        for sid in ins:
            segment = layout.segment(sid)
            if segment.bidirectional:
                continue
            arrive = _heading(layout.segment_coords(sid), at_end=True)
            turns = all(
                abs(math.remainder(_heading(coords, at_end=False) - arrive, math.tau)) > _TURN_RAD
                for out, forward in outs
                if out != sid and (not layout.segment(out).bidirectional or out in ways_through)
                for coords in [layout.segment_coords(out)[:: 1 if forward else -1]]
            )
            if crossing or turns:
                branches.add(sid)
    return frozenset(branches)


@functools.lru_cache(maxsize=4)
def turn_offs(layout: Layout) -> frozenset[tuple[str, str]]:
    """The turns off a one-way lane: pairs ``(lane segment, segment turned into)``
    where the lane goes on straight past the junction and the other segment leaves it
    at a wider angle than a branch meets its way on.

    An AGV at rest just after such a turn still has the back of its hull in the lane;
    the next AGV along the lane waits for it, and if the first one's way on comes
    round to that place, each waits for the other for ever (docs/traffic.md,
    "Turning off a one-way lane"). Its route gets a no-rest zone from the
    junction to the clearance beyond it
    (:meth:`~agv_app.traffic.deadlock.StopPlan.for_route`), as a merge gets one before
    it. A two-way lane needs none: its zone reaches the clearance
    beyond its end already.
    """
    pairs: set[tuple[str, str]] = set()
    for lane in layout.segments.values():
        if lane.bidirectional:
            continue
        arrive = _heading(layout.segment_coords(lane.id), at_end=True)
        straight: list[str] = []
        turning: list[str] = []
        for target in layout.successors(lane.end):
            out = layout.segment_between(lane.end, target)
            if out is None or out == lane.id:
                continue
            coords = layout.segment_coords(out)
            if layout.segment(out).end == lane.end:
                coords = coords[::-1]
            bend = abs(math.remainder(_heading(coords, at_end=False) - arrive, math.tau))
            (turning if bend > _TURN_RAD else straight).append(out)
        if straight:
            pairs.update((lane.id, out) for out in turning)
    return frozenset(pairs)


@functools.lru_cache(maxsize=4)
def _ways_out(layout: Layout) -> dict[str, frozenset[str]]:
    """The ways out found so far on ``layout``, by point (filled by :func:`way_out`)."""
    return {}


def way_out(layout: Layout, point: str) -> frozenset[str]:
    """The segments every AGV leaving ``point`` must drive: from ``point`` on for as
    long as each point reached has one way on (not counting the way back), up to the
    first point with two or more. An AGV bound for ``point`` must not rest on them
    where its request would reach ``point``
    (:meth:`~agv_app.traffic.deadlock.StopPlan.for_route`): the AGV standing there (at a
    dead-end dock, after its dwell) leaves by them, and the two would wait on each other
    for ever (docs/traffic.md, "Waiting for a station")."""
    known = _ways_out(layout)
    found = known.get(point)
    if found is None:
        found = known[point] = _trace_way_out(layout, point)
    return found


def _trace_way_out(layout: Layout, point: str) -> frozenset[str]:
    segments: list[str] = []
    visited = {point}
    came_by: str | None = None
    at = point
    while True:
        ways = [
            (target, seg)
            for target in layout.successors(at)
            for seg in [layout.segment_between(at, target)]
            if seg is not None and seg != came_by
        ]
        if len(ways) != 1 or ways[0][0] in visited:
            return frozenset(segments)
        at, came_by = ways[0]
        visited.add(at)
        segments.append(came_by)
