"""Where a following request may end: never inside a part of a zone without a claim
(``StopPlan.hard``), on any route of the floors the fleet runs on (docs/traffic.md,
"Request length")."""

from __future__ import annotations

import functools

from hypothesis import given, settings
from hypothesis import strategies as st

from agv_app.fleet import Fleet, FleetConfig
from agv_app.layout.demo import demo_warehouse
from agv_app.layout.generated import generated_warehouse
from agv_app.traffic.deadlock import StopPlan
from agv_app.vehicle import AgvController

FLOORS = ("demo", "generated:12")


@functools.cache
def _agv(floor: str) -> AgvController:
    """An AGV on ``floor`` that plans routes under the fleet's rules."""
    layout = demo_warehouse() if floor == "demo" else generated_warehouse(12)
    fleet = Fleet(layout, FleetConfig(agvs=1, seed=1, task_interval=1e9, start_tasks=0))
    return fleet.agvs["agv-01"]


@functools.cache
def _plan(floor: str, pick: int, drop: int) -> StopPlan:
    agv = _agv(floor)
    stations = agv.layout.usable_stations()
    a = agv.layout.station(stations[pick % len(stations)]).point
    b = agv.layout.station(stations[drop % len(stations)]).point
    return agv.routing.plan_for(agv.layout.route(a, b))


@settings(max_examples=300, deadline=None)
@given(
    floor=st.sampled_from(FLOORS),
    pick=st.integers(0, 10_000),
    drop=st.integers(0, 10_000),
    at=st.floats(0.0, 1.0),
    advance=st.floats(1.25, 8.0),
)
def test_a_following_request_never_ends_in_a_part_without_a_claim(
    floor: str, pick: int, drop: int, at: float, advance: float
) -> None:
    plan = _plan(floor, pick, drop)
    start = at * plan.length
    stop = plan.next_stop(start, advance, follow=True)
    assert stop >= min(start + advance, plan.length) - 1e-9
    if stop < plan.length:
        assert not any(lo < stop < hi for lo, hi in plan.hard), (stop, plan.hard)
        # Inside a zone only where the route drives through it, with its claims.
        for k, (lo, hi) in enumerate(plan.zones):
            if lo < stop < hi:
                assert plan.through[k]
                assert plan.claims_between(start, stop)
