"""How far an AGV's hull projection can reach, and the interest radius that follows.

An AGV publishes ``hull_length``: the distance from its position to the furthest point
of its locked and requested projections. Two AGVs can only conflict when their circles
overlap (``|p_i - p_j| <= r_i + r_j``), so a node that hears every AGV within twice the
largest hull length any AGV can publish hears every member of every collision group it
may form or vote in. :func:`largest_hull_length` bounds that length from the layout and
the controller's rules, :func:`dissemination_margin` adds a margin for movement between
property updates, for network delay and for detecting a crash.

With footprints (``NodeConfig.footprint_margin``) a node publishes to the cells within
its own hull length plus half the margin and listens over the largest hull length plus
the other half, so it hears every AGV whose circle may meet any circle it may publish
(:func:`interest_radius`). docs/traffic.md ("Why the interest radius keeps every
collider in the group") gives the argument.

The bound follows the request rule of :class:`~agv_app.vehicle.controller.AgvController`:
a request is made when the locked stretch ahead is at most ``need`` long (braking
distance plus the distance driven in the safe time and half a second), and ends at
:meth:`~agv_app.traffic.deadlock.StopPlan.next_stop`: at least ``advance_m`` further,
pushed to the end of a no-rest zone when it would end inside one, and to the route's
end when less than a quarter of ``advance_m`` would remain. A zone is a run of
bidirectional segments, joined to the next one when the one-way stretch between them
is shorter than twice the clearance (:func:`longest_no_rest_zone`).
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

from agv_app.layout.graph import Layout
from agv_app.traffic.deadlock import clearance_for
from agv_app.vehicle.controller import AgvConfig
from agv_app.vehicle.kinematics import VehicleSpec

__all__ = [
    "dissemination_margin",
    "interest_radius",
    "largest_hull_length",
    "longest_no_rest_zone",
    "unheard_colliders",
]

_ROUNDING_M = 0.02  # the published length is rounded up to millimetres; the lead-in piece


def longest_no_rest_zone(layout: Layout, clearance_m: float) -> float:
    """An upper bound on the length of any merged no-rest zone of any route.

    A zone covers consecutive bidirectional segments of a route, each widened by the
    clearance at both ends; two of them merge when the one-way stretch between them is
    at most twice the clearance. A route is a simple path, so it uses a segment at most
    once, and a segment ending in a dead end only as its first or last one. Hence a
    zone is at most: the bidirectional segments of one linked group that do not end in
    a dead end, a gap of twice the clearance for each link in that group, two dead-end
    segments with their links, and the clearance at both ends.
    """
    bidirectional = [s for s in layout.segments.values() if s.bidirectional]
    if not bidirectional:
        return 0.0
    dead_ends = {pid for pid in layout.points if len(layout.neighbours(pid)) <= 1}
    gap_m = 2 * clearance_m
    through = [s for s in bidirectional if s.start not in dead_ends and s.end not in dead_ends]
    leaf_m = max(
        (layout.segment_length(s.id) for s in bidirectional if s not in through), default=0.0
    )
    # Group the through segments: shared end points, or one-way links of at most gap_m.
    parent = {s.id: s.id for s in through}

    def find(x: str) -> str:
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    ends: dict[str, list[str]] = {}
    for s in through:
        ends.setdefault(s.start, []).append(s.id)
        ends.setdefault(s.end, []).append(s.id)
    links: list[tuple[str, str]] = []
    for point, segs in ends.items():
        for other in _one_way_reach(layout, point, gap_m):
            if other in ends and other > point:
                links.append((segs[0], ends[other][0]))
        for seg in segs[1:]:
            parent[find(seg)] = find(segs[0])
    for a, b in links:
        parent[find(a)] = find(b)
    total: dict[str, float] = {}
    for s in through:
        root = find(s.id)
        total[root] = total.get(root, 0.0) + layout.segment_length(s.id)
    for a, _ in links:
        root = find(a)
        total[root] += gap_m
    group_m = max(total.values(), default=0.0)
    return group_m + 2 * (leaf_m + gap_m) + gap_m


def _one_way_reach(layout: Layout, source: str, limit_m: float) -> Iterable[str]:
    """Points within ``limit_m`` of ``source`` over one-way segments, either direction."""
    best = {source: 0.0}
    queue = [(0.0, source)]
    while queue:
        d, point = heapq.heappop(queue)
        if d > best.get(point, math.inf):
            continue
        for nb in layout.neighbours(point):
            seg_id = layout.segment_between(point, nb) or layout.segment_between(nb, point)
            if seg_id is None or layout.segment(seg_id).bidirectional:
                continue
            nd = d + layout.segment_length(seg_id)
            if nd <= limit_m and nd < best.get(nb, math.inf):
                best[nb] = nd
                heapq.heappush(queue, (nd, nb))
    best.pop(source)
    return best.keys()


def largest_hull_length(layout: Layout, spec: VehicleSpec, config: AgvConfig) -> float:
    """An upper bound on the ``hull_length`` any AGV on ``layout`` can publish, metres.

    The locks ahead are at most ``need`` long when a request is made, the request adds
    at most ``1.25 * advance_m`` plus the longest no-rest zone, and every point of a
    hull projection lies within half the hull's diagonal of the route. Locks behind the
    vehicle (released every ``t_update``) reach less far. Direction claims count too:
    a request claims the segments of the zones it reaches into, and the zone it ends in
    began before its first target (``advance_m`` beyond the locks), so a claimed segment
    ends within the same bound; claims kept at a route's end lie on the segment the AGV
    stands on. No AGV reaches beyond the floor either: the diagonal of the layout's
    bounds caps the length.
    """
    clearance = clearance_for(spec.length_m, spec.width_m)
    need = spec.braking_distance(spec.max_speed_m_s) + spec.max_speed_m_s * (
        2 * config.t_update + 0.5
    )
    request = 1.25 * config.advance_m + longest_no_rest_zone(layout, clearance)
    along = min(need + request, layout.diagonal())
    half_diagonal = math.hypot(spec.length_m / 2, spec.width_m / 2)
    return along + half_diagonal + config.hull_margin_m + _ROUNDING_M


def dissemination_margin(
    spec: VehicleSpec,
    config: AgvConfig,
    *,
    delay_s: float = 0.0,
    failure_detection_s: float = 0.0,
) -> float:
    """How much further than two circles' reach an AGV must hear the other, metres.

    The distance two AGVs may close while one update interval and two network delays
    pass (both at top speed), plus the distance an AGV covers towards a crashed one
    before the failure is detected and relayed (:mod:`agv_app.traffic.stale_relay`).

    Args:
        spec: the vehicles' size and speed.
        config: the AGV component's tunables (``t_update``).
        delay_s: the largest one-way network delay.
        failure_detection_s: the longest from a node's last frame until its failure is
            found (``NodeConfig.failure_detection_bound``: four thirds of the timeout,
            more for a node at rest); 0: no crash to relay.
    """
    speed = spec.max_speed_m_s
    movement = 2 * speed * (config.t_update + 2 * delay_s)
    detection = speed * (failure_detection_s + 2 * delay_s) if failure_detection_s else 0.0
    return movement + detection


def interest_radius(
    layout: Layout,
    spec: VehicleSpec,
    config: AgvConfig,
    *,
    delay_s: float = 0.0,
    failure_detection_s: float = 0.0,
    footprints: bool = False,
) -> float:
    """The interest radius of an AGV node: every possible collider of its requests, and
    every requester it may vote for, lies within it (or, with footprints, has its
    footprint reach into it).

    Without footprints (every node publishes in its own cell): twice the largest hull
    length (both circles at their largest) plus the dissemination margin. With
    footprints: the largest hull length plus half the margin; the other AGV's
    footprint adds its own hull length and the other half (its footprint margin).

    Args:
        layout: the floor plan.
        spec: the vehicles' size and speed.
        config: the AGV component's tunables (``t_update``, ``advance_m``).
        delay_s: the largest one-way network delay.
        failure_detection_s: the longest until a crash is found (0: no crash to relay).
        footprints: the nodes publish to their footprints.
    """
    margin = dissemination_margin(
        spec, config, delay_s=delay_s, failure_detection_s=failure_detection_s
    )
    largest = largest_hull_length(layout, spec, config)
    return largest + margin / 2 if footprints else 2 * largest + margin


def unheard_colliders(
    published: Mapping[str, Mapping[str, Any]], heard: Mapping[str, Iterable[str]]
) -> list[tuple[str, str]]:
    """Pairs ``(listener, other)`` of AGVs whose published circles overlap, where the
    listener does not hear the other: a collision group that could miss a member.

    Args:
        published: each AGV's own properties (``position``, ``hull_length``).
        heard: each AGV's view, the ids of the nodes it hears.
    """
    ids = sorted(published)
    circles = [_circle(published[i]) for i in ids]
    views = {i: frozenset(heard.get(i, ())) for i in ids}
    missed: list[tuple[str, str]] = []
    for a, ca in zip(ids, circles, strict=True):
        for b, cb in zip(ids, circles, strict=True):
            if a == b or ca is None or cb is None or b in views[a]:
                continue
            if math.hypot(ca[0] - cb[0], ca[1] - cb[1]) <= ca[2] + cb[2]:
                missed.append((a, b))
    return missed


def _circle(props: Mapping[str, Any]) -> tuple[float, float, float] | None:
    pos, radius = props.get("position"), props.get("hull_length")
    if isinstance(pos, Sequence) and len(pos) == 2 and isinstance(radius, int | float):
        return (float(pos[0]), float(pos[1]), float(radius))
    return None
