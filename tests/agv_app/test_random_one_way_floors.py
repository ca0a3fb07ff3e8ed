"""Deadlock freedom on random one-way floors (``tests/agv_app/one_way_floors.py``): a
random fleet runs a random task stream; no collision, no lock overlap, no AGV stalled
past the stall limit and no wait past the fleet's wait bound may happen (docs/traffic.md,
"Merges and crossings of one-way lanes", "Waiting for a station on its AGV's way out",
"Driving on", "Bounded waits").
``python -m tests.soak.floors`` runs many more seeds of the same drawing.
"""

from __future__ import annotations

import random
from typing import Any

import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from agv_app.traffic.deadlock import merge_branches
from tests.agv_app.one_way_floors import (
    FloorRun,
    draw_floor_run,
    one_way_floor,
    run_floor,
)
from tests.agv_app.test_random_layouts import FLEET_EXAMPLES
from tests.agv_app.vehicles import FOUND_AT, vehicle_with


def test_the_floors_have_merges_without_boxes() -> None:
    floor = one_way_floor(8, 20.0, {3: "n", 5: "s"}, middle=True, agvs=4)
    # Both aisles turn into the lane they end on, both cross the middle lane (each way
    # into a crossing is a branch), and the middle lane turns into the east column.
    assert merge_branches(floor.layout) == {
        "a3n>n3",
        "a5s>s5",
        "a3s>m3",
        "m2>m3",
        "a5n>m5",
        "m4>m5",
        "m7>c8y1",
    }


# Floors, seeds and loads on which AGVs locked at a merge without the rule (4 to 6
# AGVs over 180 s, 0 to 18 tasks done): sampled at random, as the strategy draws them.
# The before-and-after tests here replay them as they were found, with stations that
# call every winner at once (``one_at_a_time=False``): AGVs queued at the docks make
# the hard case, and a traffic rule must hold whatever the task assignment does.
_LOCKED = [
    FloorRun(one_way_floor(9, 16.0, {3: "s", 5: "s", 7: "n"}, middle=True, agvs=5), 9755, 0.9),
    FloorRun(one_way_floor(8, 16.0, {5: "s"}, middle=True, agvs=6), 625, 1.0),
    FloorRun(one_way_floor(9, 12.0, {4: "n", 5: "s", 6: "n"}, middle=True, agvs=5), 1269, 1.0),
    FloorRun(one_way_floor(8, 12.0, {3: "n", 5: "n"}, middle=True, agvs=5), 2910, 0.9),
]


@pytest.mark.slow
def test_without_the_rule_these_floors_lock() -> None:
    """What the examples below replay: each of them locks without the rule (and
    without the turn-off rule, which keeps seed 625's AGV off the lane as well)."""
    for run in _LOCKED:
        fleet = run_floor(
            run,
            one_at_a_time=False,
            **FOUND_AT,
            vehicle=vehicle_with(clear_merges=False, clear_turn_offs=False),
        )
        assert fleet.summary()["deadlocks"] > 0, run


# The four floors above and up to ten drawn fleet runs of 500 simulated seconds with up
# to 8 AGVs (a few seconds of CPU each); `make soak-floors` runs 300 more draws.
@pytest.mark.slow
@pytest.mark.timeout(900)
@settings(FLEET_EXAMPLES, max_examples=10)
@given(run=st.randoms(use_true_random=False).map(draw_floor_run))
@example(run=_LOCKED[0])
@example(run=_LOCKED[1])
@example(run=_LOCKED[2])
@example(run=_LOCKED[3])
def test_random_one_way_floors_never_stall(run: FloorRun) -> None:
    fleet = run_floor(run)
    figures = fleet.summary()
    stuck = {a: (agv.phase, agv.point) for a, agv in fleet.agvs.items() if agv.stalled}
    assert figures["collisions"] == figures["lock_overlaps"] == 0
    assert figures["deadlocks"] == 0, f"{run}: stalled {stuck}"
    assert figures["max_wait"] <= figures["wait_bound"], f"{run}: {fleet.wait_bound}"
    assert figures["tasks_completed"] >= 1, f"{run}: nothing done"


# Two crowded draws (of 200) that locked with the merge rule alone: an AGV bound for a
# dock off an aisle waited on the north lane, or just after turning off it, and the
# dock's AGV had to leave along that lane. With requests served oldest first at every
# conflict (agv_app.traffic.fifo) the dock's AGV inherits the age of the request it
# holds up and leaves first, so they no longer lock even without the way-out and
# turn-off rules; both ways they stay safe, free of stalls and within the wait bound.
_DOCK_WAITS = [
    FloorRun(one_way_floor(8, 12.0, {4: "n", 3: "s"}, middle=True, agvs=5), 6305, 1.0),
    FloorRun(one_way_floor(8, 12.0, {6: "n", 5: "n", 4: "s"}, middle=True, agvs=4), 2680, 1.0),
]


@pytest.mark.slow
@pytest.mark.parametrize("run", _DOCK_WAITS)
@pytest.mark.parametrize("rules", ["default", "no way-out, no turn-off"])
def test_an_agv_waiting_for_a_dock_lets_the_docks_agv_out(run: FloorRun, rules: str) -> None:
    options: dict[str, Any] = {}
    if rules != "default":
        options["vehicle"] = vehicle_with(keep_way_out=False, clear_turn_offs=False)
    fleet = run_floor(run, one_at_a_time=False, **FOUND_AT, **options)
    figures = fleet.summary()
    assert figures["deadlocks"] == figures["collisions"] == figures["lock_overlaps"] == 0
    assert figures["max_wait"] <= figures["wait_bound"], f"{run}: {fleet.wait_bound}"
    assert figures["tasks_completed"] >= 5, figures["tasks_completed"]


# Seed 126 of the floor runner (``python -m tests.soak.floors --seed 126``), which locked
# with the way-out rule: an AGV waits for a dock off an aisle on the north lane, clear of
# the dock's way out, and three AGVs bound elsewhere queue behind it; the dock's AGV
# leaves round a short loop (down its aisle, along the middle lane, up the next aisle)
# whose first request reaches onto the north lane, into the queue.
_QUEUED = FloorRun(
    one_way_floor(10, 12.0, {6: "n", 5: "s", 3: "s"}, middle=True, agvs=5), 7976, 0.7
)


def test_the_queued_floor_is_seed_126_of_the_runner() -> None:
    drawn = draw_floor_run(random.Random(126))
    assert (repr(drawn.floor), drawn.seed, drawn.load) == (
        repr(_QUEUED.floor),
        _QUEUED.seed,
        _QUEUED.load,
    )


# The fleets that locked on seed 126 without a rule, as they were found: without
# driving on (the AGV held up before its dock), without the turn-off rule and with
# drop stations that take any number of loads (an AGV resting just past its turn off
# the lane, the back of its hull in it), and without taking another way (a one-way loop
# of four segments filled with three AGVs: the "full loop" of docs/traffic.md). With
# requests served oldest first at every conflict (agv_app.traffic.fifo), the AGV whose
# lock holds up an older request inherits its age and moves first, and none of them
# locks; each must stay safe, free of stalls and within the wait bound.
_SEED_126_WITHOUT: dict[str, dict[str, Any]] = {
    "driving on": {
        "one_at_a_time": False,
        **FOUND_AT,
        "vehicle": vehicle_with(drive_on_after=None, clear_turn_offs=False),
    },
    "the turn-off rule": {
        "wait_for_drop": False,
        **FOUND_AT,
        "vehicle": vehicle_with(clear_turn_offs=False),
    },
    "another way": {
        "republish": 60.0,
        "probes": False,
        "station_nodes": True,
        "max_open_tasks": None,
        "vehicle": vehicle_with(detour_after=None),
    },
}


@pytest.mark.slow
@pytest.mark.parametrize("without", sorted(_SEED_126_WITHOUT))
def test_the_queued_floor_no_longer_locks_without_a_last_resort(without: str) -> None:
    fleet = run_floor(_QUEUED, **_SEED_126_WITHOUT[without])
    figures = fleet.summary()
    assert figures["deadlocks"] == figures["collisions"] == figures["lock_overlaps"] == 0
    assert figures["max_wait"] <= figures["wait_bound"], f"{without}: {fleet.wait_bound}"
    assert figures["tasks_completed"] >= 10, figures["tasks_completed"]
