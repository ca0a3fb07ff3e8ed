"""How long an AGV can wait, read off the layout and the fleet.

Requests are served oldest first at every conflict (:mod:`agv_app.traffic.fifo`), so a
waiting AGV waits only for what the others do before it: docs/traffic.md, "Bounded
waits", argues that each of the other ``N - 1`` AGVs keeps it at most one **visit**
(drives into its way, dwells there, drives out again), and that its own request is
granted a **latency** after the last of them has gone:

    B = (N - 1) * V + L,    V = 2 * P + dwell,    P = drive(longest request) + handover

* the **longest request** is the longest stretch an AGV asks for in one piece: the
  longest no-rest zone of any route between two stations or dead ends (a two-way run
  up to the next place where AGVs may rest, with the clearance at both ends, and the
  keep-clear pieces before merges, after turn-offs, on a station's way out), plus a
  request's reach (``1.25 * advance_m``); on floors with more route ends than
  :data:`EXACT_ROUTES` allows for it is the closed-form bound of
  :func:`~agv_app.traffic.reach.longest_no_rest_zone` instead, which is looser;
* a **pass** ``P`` drives it from a standstill at top speed and acceleration, and hands
  the floor on: the locks behind an AGV are released once per ``t_update``, a voter
  looks again every ``t_update / 2``, a vote and a grant cross the network twice, and
  the simulation moves in steps;
* the **latency** ``L`` is what the waiting AGV's own request takes once its floor is
  free: the safe time, the slack before a departure, a handover.

A plant engineer reads the fleet a floor takes for a wait limit from the same terms
(:meth:`WaitBound.fleet_within`): a longer run between resting places, or a longer
dwell at a dead-end station, costs every AGV of the fleet that much more waiting.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

from agv_app.layout.elements import NoRouteError
from agv_app.layout.graph import Layout
from agv_app.traffic.deadlock import (
    StopPlan,
    clearance_for,
    followable_segments,
    merge_branches,
    turn_offs,
)
from agv_app.traffic.reach import longest_no_rest_zone
from agv_app.vehicle.controller import AgvConfig
from agv_app.vehicle.kinematics import VehicleSpec

__all__ = ["EXACT_ROUTES", "WaitBound", "longest_request_m", "wait_bound"]

EXACT_ROUTES = 4000
"""Routes between route ends the longest request is measured on, at most; a floor with
more takes the closed-form bound."""

_DEPART_SLACK_S = 0.2  # the route is set this much before the safe time before departure


@dataclass(frozen=True, slots=True)
class WaitBound:
    """The longest an AGV of a fleet waits, and the terms it is made of (seconds,
    metres).

    Attributes:
        agvs: the fleet's size ``N``.
        longest_request_m: the longest stretch asked for in one piece.
        pass_s: ``P``, driving it from a standstill and handing the floor on.
        dwell_s: the dwell at a station.
        latency_s: ``L``, the waiting AGV's own request once its floor is free.
    """

    agvs: int
    longest_request_m: float
    pass_s: float
    dwell_s: float
    latency_s: float

    @property
    def visit_s(self) -> float:
        """``V``: one other AGV's visit in the way: in, dwell, out."""
        return 2 * self.pass_s + self.dwell_s

    @property
    def seconds(self) -> float:
        """The bound ``B = (N - 1) * V + L``."""
        return max(self.agvs - 1, 0) * self.visit_s + self.latency_s

    def for_agvs(self, agvs: int) -> WaitBound:
        """The same floor with a fleet of ``agvs``."""
        return WaitBound(agvs, self.longest_request_m, self.pass_s, self.dwell_s, self.latency_s)

    def fleet_within(self, limit_s: float) -> int:
        """The largest fleet whose bound is at most ``limit_s`` (0: not even one AGV's
        own latency fits)."""
        if limit_s < self.latency_s:
            return 0
        return 1 + math.floor((limit_s - self.latency_s) / self.visit_s + 1e-9)

    def __str__(self) -> str:
        return (
            f"{self.seconds:.1f} s = ({self.agvs} - 1) x {self.visit_s:.1f} s "
            f"(in and out {self.pass_s:.1f} s each, the longest request "
            f"{self.longest_request_m:.1f} m, dwell {self.dwell_s:g} s) "
            f"+ {self.latency_s:.1f} s"
        )


def wait_bound(
    layout: Layout,
    spec: VehicleSpec,
    config: AgvConfig,
    *,
    agvs: int,
    delay_s: float = 0.0,
    step_s: float = 0.0,
) -> WaitBound:
    """The wait bound of a fleet of ``agvs`` on ``layout`` (docs/traffic.md, "Bounded
    waits").

    Args:
        layout: the floor plan.
        spec: the vehicles' size, speed and acceleration.
        config: the AGV component's tunables (``t_update``, ``advance_m``, ``dwell``
            and the rules that shape the no-rest zones).
        agvs: the fleet's size.
        delay_s: the largest one-way network delay.
        step_s: the simulation step (0 on a real clock).
    """
    request = longest_request_m(layout, spec, config)
    t = config.t_update
    handover = t + t / 2 + 4 * delay_s + step_s
    pass_s = spec.travel_time(request) + handover
    latency = 2 * t + _DEPART_SLACK_S + handover
    return WaitBound(agvs, request, pass_s, config.dwell, latency)


def longest_request_m(layout: Layout, spec: VehicleSpec, config: AgvConfig) -> float:
    """The longest stretch an AGV on ``layout`` asks for in one piece, metres.

    A request reaches from a resting place at least ``advance_m`` on; one that would end
    inside a no-rest zone reaches to its end, and one that would leave less than a
    quarter of ``advance_m`` before the route's end reaches the end. So it is at most a
    zone's length plus ``1.25 * advance_m``, and no longer than the route. Measured on
    the routes between every two route ends (stations and dead ends), with the zones
    the controller's rules give them; the closed-form bound where those are more than
    :data:`EXACT_ROUTES`.
    """
    return _longest_request(layout, spec.length_m, spec.width_m, config)


@functools.lru_cache(maxsize=16)
def _longest_request(layout: Layout, length_m: float, width_m: float, config: AgvConfig) -> float:
    clearance = clearance_for(length_m, width_m)
    reach = 1.25 * config.advance_m
    ends = sorted(
        {layout.station(s).point for s in layout.stations}
        | {p for p in layout.points if len(layout.neighbours(p)) <= 1}
    )
    if len(ends) * (len(ends) - 1) > EXACT_ROUTES:
        return reach + longest_no_rest_zone(layout, clearance)
    followable = followable_segments(layout) if config.direction_claims else frozenset()
    merges = merge_branches(layout) if config.clear_merges else frozenset()
    turns = turn_offs(layout) if config.clear_turn_offs else frozenset()
    longest = 0.0
    for a in ends:
        for b in ends:
            if a == b:
                continue
            try:
                route = layout.route(a, b)
            except NoRouteError:
                continue
            plan = StopPlan.for_route(
                layout,
                route,
                clearance_m=clearance,
                followable=followable,
                merges=merges,
                merge_box_m=(length_m + width_m) / 2,
                turns=turns,
                way_out_reach_m=config.advance_m if config.keep_way_out else None,
            )
            zone = max((min(hi, route.length) - max(lo, 0.0) for lo, hi in plan.zones), default=0.0)
            longest = max(longest, min(route.length, zone + reach))
    return longest
