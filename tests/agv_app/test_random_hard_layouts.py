"""Bounded waits on the shapes that make AGVs wait long (``tests/agv_app/hard_floors.py``):
two-way lanes crossing with stations and parking at the arms' ends, a lane (or a lane
with a lay-by) between two dead-end areas, one-way halls joined by a two-way door. A
random fleet runs a random task stream; the run must have no collision, no lock
overlap, no AGV stalled past the stall limit and no wait past the fleet's wait bound
(docs/traffic.md, "Bounded waits"). ``python -m tests.soak.floors --kind crossing``
(``areas``, ``halls``) runs many more seeds of the same drawings.
"""

from __future__ import annotations

import random

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from agv_app.fleet import Fleet, FleetConfig
from tests.agv_app.hard_floors import DRAWS, HardRun, draw_areas_run, run_hard
from tests.agv_app.test_random_layouts import FLEET_EXAMPLES


def _check(run: HardRun) -> None:
    fleet = run_hard(run)
    figures = fleet.summary()
    stuck = {a: (agv.phase, agv.point) for a, agv in fleet.agvs.items() if agv.stalled}
    assert figures["collisions"] == figures["lock_overlaps"] == 0
    assert figures["deadlocks"] == 0, f"{run}: stalled {stuck}"
    assert figures["max_wait"] <= figures["wait_bound"], f"{run}: {fleet.wait_bound}"
    assert figures["tasks_completed"] >= 1, f"{run}: nothing done"


def test_an_areas_seed_draws_a_lane_between_two_dead_end_areas() -> None:
    run = draw_areas_run(random.Random(46))
    assert run.floor.shape == "lane 15 m, stations (2, 1), parking (1, 1)"
    _check(run)  # a visit of the other AGV held its wait up: in, dwell, out


def test_halls_seed_125_never_sends_two_agvs_head_on_into_the_door() -> None:
    # Each AGV allowed the other's stretch into the door, the other way (disjoint
    # areas, conflicting direction claims) and ranked its own above it: both locked,
    # met inside the door and waited there for good.
    run = DRAWS["halls"](random.Random(125))
    assert run.floor.shape == "halls 15 m, door 8 m, stations (3, 2), parking (3, 2)"
    _check(run)


def test_crossing_seed_158_rests_every_agv_at_a_place_of_its_own() -> None:
    # An AGV that yielded on its way home to a new home went on to the home it had
    # given up; two AGVs then stood each at the other's dead-end spot, bound for it.
    run = DRAWS["crossing"](random.Random(158))
    assert run.floor.shape == "crossing arms [8.0, 8.0, 15.0], parking 2 per arm 5 m on"
    _check(run)


# Six fleet runs of 500 simulated seconds per shape, up to 8 AGVs (a few seconds of
# CPU each).
@pytest.mark.slow
@pytest.mark.timeout(900)
@pytest.mark.parametrize("kind", sorted(DRAWS))
def test_random_hard_layouts_keep_every_wait_within_the_bound(kind: str) -> None:
    @settings(FLEET_EXAMPLES, max_examples=6)
    @given(run=st.randoms(use_true_random=False).map(DRAWS[kind]))
    def check(run: HardRun) -> None:
        _check(run)

    check()


# Three runs per shape with a wait limit that puts two AGVs in service: the others
# never move, and no wait passes the bound of the two.
@pytest.mark.slow
@pytest.mark.timeout(900)
@pytest.mark.parametrize("kind", sorted(DRAWS))
def test_random_hard_layouts_with_a_wait_limit_keep_the_reserve_parked(kind: str) -> None:
    @settings(FLEET_EXAMPLES, max_examples=3)
    @given(run=st.randoms(use_true_random=False).map(DRAWS[kind]))
    def check(run: HardRun) -> None:
        whole = Fleet(run.floor.layout, FleetConfig(agvs=run.floor.agvs, seed=run.seed))
        limit = whole.wait_bound.for_agvs(2).seconds
        fleet = run_hard(run, wait_limit=limit)
        assert fleet.active == min(2, run.floor.agvs)
        reserve = set(sorted(fleet.agvs)[fleet.active :])
        figures = fleet.summary()
        assert figures["collisions"] == figures["lock_overlaps"] == 0
        assert figures["max_wait"] <= figures["wait_bound"], f"{run}"
        assert fleet.wait_bound.seconds <= limit + 1e-9
        moved = {r.vehicle for r in fleet.desk.book.records()} & reserve
        assert not moved, f"{run}: reserve AGVs took tasks: {moved}"
        homes = dict(zip(sorted(fleet.agvs), fleet.parking.homes, strict=True))
        away = {a for a in reserve if fleet.agvs[a].point != homes[a]}
        assert not away, f"{run}: reserve AGVs left home: {away}"

    check()
