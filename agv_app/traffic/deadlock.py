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
place.

Waiting for a station. An AGV bound for a station another one stands at waits at the
last resting place before it; on a one-way floor that place may lie on the way the
standing AGV must leave by, and then each waits for the other. So, near the end of a
route, the destination's way out (:func:`way_out`) is no resting place either. See
docs/traffic.md for the whole argument and its limits.

This module holds the claims and the resting places of a route (:class:`StopPlan`); the
features of a layout's shape they rest on are read in
:mod:`agv_app.traffic.floor_features` and re-exported here.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

from agv_app.layout.elements import Route
from agv_app.layout.graph import Layout
from agv_app.traffic.floor_features import (
    followable_segments,
    merge_branches,
    turn_offs,
    way_out,
)

__all__ = [
    "DEFAULT_CLEARANCE_M",
    "Claim",
    "StopPlan",
    "claims_conflict",
    "clearance_for",
    "followable_segments",
    "merge_branches",
    "turn_offs",
    "way_out",
]

Claim = tuple[str, int]
"""A direction claim on one two-way segment: ``(segment id, direction)``, direction
``1`` along the segment (start to end), ``-1`` against it, ``0`` to stop on it."""


def claims_conflict(ours: Iterable[Claim], theirs: Iterable[Claim]) -> bool:
    """True if two sets of claims may not be held at once: the same segment, unless
    both drive through it the same way (same-direction AGVs follow each other)."""
    held: dict[str, set[int]] = {}
    for seg, way in ours:
        held.setdefault(seg, set()).add(way)
    for seg, way in theirs:
        for other in held.get(seg, ()):
            if way == 0 or other == 0 or way != other:
                return True
    return False


def clearance_for(length_m: float, width_m: float, *, margin_m: float = 0.15) -> float:
    """Distance an AGV's centre keeps from a bidirectional run it waits to enter.

    Its front (half a length ahead) must stay out of the circle another AGV of the
    same size sweeps while turning on the spot at the run's mouth.
    """
    return length_m / 2 + math.hypot(length_m / 2, width_m / 2) + margin_m


DEFAULT_CLEARANCE_M = clearance_for(2.0, 1.0)
"""The clearance for the demo's 2 m x 1 m vehicles."""


def _merged(
    raw: list[tuple[float, float, list[Claim]]],
) -> list[tuple[float, float, list[Claim]]]:
    """Zones sorted, those that overlap or touch merged into one, claims joined."""
    merged: list[tuple[float, float, list[Claim]]] = []
    for lo, hi, claims in sorted(raw, key=lambda z: (z[0], z[1])):
        if merged and lo <= merged[-1][1]:
            last = merged[-1]
            merged[-1] = (last[0], max(last[1], hi), last[2] + claims)
        else:
            merged.append((lo, hi, claims))
    return merged


@dataclass(frozen=True, slots=True)
class StopPlan:
    """The resting places of one route.

    Attributes:
        length: route length, metres.
        zones: merged open intervals ``(lo, hi)`` of arc length where the AGV must not
            rest (the route end is always allowed).
        claims: per zone, the direction claims on its two-way segments (empty: none
            computed).
        through: per zone, True if the route leaves it at its far end (a passing
            place, then on beyond the clearance): with its claims held the AGV may
            rest inside it behind one going the same way.
        spans: each claim with the arc lengths ``(lo, hi)`` where the hull covers its
            segment (widened by the clearance).
        clearance: the clearance the zones are widened by.
        hard: the parts of zones that carry no claim (a spur or lane that ends in a
            dead end, a keep-clear box, a turn off a lane, a way out), merged: no AGV
            rests inside them, following or not.
    """

    length: float
    zones: tuple[tuple[float, float], ...]
    claims: tuple[tuple[Claim, ...], ...] = ()
    through: tuple[bool, ...] = ()
    spans: tuple[tuple[Claim, float, float], ...] = ()
    clearance: float = 0.0
    hard: tuple[tuple[float, float], ...] = ()

    @classmethod
    def for_route(
        cls,
        layout: Layout,
        route: Route,
        *,
        clearance_m: float,
        followable: frozenset[str] = frozenset(),
        merges: frozenset[str] = frozenset(),
        merge_box_m: float = 0.0,
        turns: frozenset[tuple[str, str]] = frozenset(),
        way_out_reach_m: float | None = None,
    ) -> StopPlan:
        """Compute the no-rest zones of ``route`` on ``layout`` and the direction claims
        on those of their segments that are ``followable`` (none by default).

        A segment of the route in ``merges`` (:func:`merge_branches`) ends in a zone as
        a keep-clear box of ``merge_box_m`` would: from ``merge_box_m`` plus the
        clearance before its junction to the clearance beyond it. A turn of the route
        in ``turns`` (:func:`turn_offs`) starts one: from its junction to the clearance
        beyond it.

        With ``way_out_reach_m`` (how far a request reaches), a segment of the
        destination's :func:`way_out` is a zone too, widened by the clearance at both
        ends, where a request from it would reach the destination: where it lies
        within that reach (and a quarter more, and the clearance) of the last resting
        place before the destination, and again from the new last one. There an AGV
        would wait for the AGV standing at the destination on the way that one leaves
        by.
        """
        exits = way_out(layout, route.end) if way_out_reach_m is not None else frozenset()
        raw: list[tuple[float, float, list[Claim]]] = []
        leaving: list[tuple[float, float]] = []
        spans: list[tuple[str, float, float]] = []
        for i, seg_id in enumerate(route.segments):
            segment = layout.segment(seg_id)
            if i and (route.segments[i - 1], seg_id) in turns:
                raw.append((route.offsets[i], route.offsets[i] + clearance_m, []))
            if seg_id in merges:
                junction = route.offsets[i + 1]
                raw.append((junction - merge_box_m - clearance_m, junction + clearance_m, []))
            if seg_id in exits:
                leaving.append((route.offsets[i] - clearance_m, route.offsets[i + 1] + clearance_m))
            if not segment.bidirectional:
                continue
            extent = layout.passing_extent(route, i)
            lo = route.offsets[i] - clearance_m
            hi = max(route.offsets[i + 1], extent.s) + clearance_m
            way = 1 if route.points[i] == segment.start else -1
            if seg_id not in followable:
                raw.append((lo, hi, []))
                continue
            raw.append((lo, hi, [(seg_id, way)]))
            spans.append(
                (seg_id, route.offsets[i] - clearance_m, route.offsets[i + 1] + clearance_m)
            )
        merged = _merged(raw)
        leaving_near: list[tuple[float, float]] = []
        if way_out_reach_m is not None:
            reach = 1.25 * way_out_reach_m + clearance_m
            while leaving:
                approach = next((lo for lo, hi, _ in merged if hi >= route.length), route.length)
                near = [(lo, hi) for lo, hi in leaving if lo < approach and hi > approach - reach]
                if not near:
                    break
                leaving = [span for span in leaving if span not in near]
                leaving_near += near
                merged = _merged(merged + [(lo, hi, []) for lo, hi in near])
        through = tuple(bool(zone) and hi < route.length - 1e-9 for _, hi, zone in merged)
        per_zone = tuple(
            tuple(c if leaves else (c[0], 0) for c in zone)
            for (_, _, zone), leaves in zip(merged, through, strict=True)
        )
        kind = {c[0]: c for zone in per_zone for c in zone}
        unclaimed = [(lo, hi) for lo, hi, claims in raw if not claims] + leaving_near
        hard = _merged([(lo, hi, list[Claim]()) for lo, hi in unclaimed])
        return cls(
            route.length,
            tuple((lo, hi) for lo, hi, _ in merged),
            per_zone,
            through,
            tuple((kind[seg], lo, hi) for seg, lo, hi in spans),
            clearance_m,
            tuple((lo, hi) for lo, hi, _ in hard),
        )

    def shifted(self, ds: float) -> StopPlan:
        """The same plan on a route ``ds`` metres longer at its start."""
        return StopPlan(
            self.length + ds,
            tuple((lo + ds, hi + ds) for lo, hi in self.zones),
            self.claims,
            self.through,
            tuple((c, lo + ds, hi + ds) for c, lo, hi in self.spans),
            self.clearance,
            tuple((lo + ds, hi + ds) for lo, hi in self.hard),
        )

    def cut(self, length: float) -> StopPlan:
        """The same plan on the route ended at ``length``, a resting place (outside
        every zone): the zones and spans beyond it are dropped."""
        keep = [k for k, (lo, _) in enumerate(self.zones) if lo < length]
        return StopPlan(
            length,
            tuple(self.zones[k] for k in keep),
            tuple(self.claims[k] for k in keep if k < len(self.claims)),
            tuple(self.through[k] for k in keep if k < len(self.through)),
            tuple(span for span in self.spans if span[1] < length),
            self.clearance,
            tuple(part for part in self.hard if part[0] < length),
        )

    def claims_between(self, s0: float, s1: float) -> frozenset[Claim]:
        """The claims of every zone that ``[s0, s1]`` reaches into."""
        return frozenset(
            c
            for (lo, hi), claims in zip(self.zones, self.claims, strict=False)
            if lo < s1 and hi > s0
            for c in claims
        )

    def claims_held(self, s: float, lock_end: float) -> frozenset[Claim]:
        """The claims an AGV at ``s`` with locks up to ``lock_end`` still needs: those
        of the zones it is in or reaches into, or, standing at the route's end, those
        of the segments its hull still covers (so that nobody follows into a run it
        may leave the other way)."""
        if s >= self.length - 1e-9:
            return frozenset(c for c, lo, hi in self.spans if lo < s < hi)
        return self.claims_between(s, lock_end)

    def may_rest(self, s: float) -> bool:
        """True if the AGV may come to rest with its centre at arc length ``s``."""
        if s >= self.length:
            return True
        return not any(lo < s < hi for lo, hi in self.zones)

    def _past_hard(self, s: float) -> float:
        """``s``, or the end of the part of :attr:`hard` it lies in."""
        for lo, hi in self.hard:
            if lo < s < hi:
                return hi
        return s

    def next_stop(self, from_s: float, advance_m: float, *, follow: bool = False) -> float:
        """The first resting place at or beyond ``from_s + advance_m`` (capped at the end).

        With ``follow``, a zone the route drives through is a resting place too (the
        request carries its direction claims, :meth:`claims_between`), outside its
        :attr:`hard` parts: at a dead-end start the spur and the box at its mouth make
        one zone with the run, and a stop just past the zone's start would leave the
        hull across the lane it joins. A stop that
        would leave less than ``advance_m / 4`` to the route end is moved to the end,
        so the last request does not cover a sliver.
        """
        target = min(from_s + advance_m, self.length)
        for k, (lo, hi) in enumerate(self.zones):
            if not lo < target < hi:
                continue
            # Following, the AGV may wait inside a run it drives through, but only with
            # its hull clear of both ends' junctions and of every part without a claim.
            first, last = lo + 2 * self.clearance + 0.01, hi - 2 * self.clearance
            if follow and k < len(self.through) and self.through[k] and first < last:
                target = self._past_hard(max(target, first))
                if target < last:
                    continue
            target = hi
        if target >= self.length - advance_m / 4:
            return self.length
        return target
