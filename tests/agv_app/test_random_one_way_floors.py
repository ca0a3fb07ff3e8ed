"""Deadlock freedom on random one-way floors (``tests/agv_app/one_way_floors.py``): a
random fleet runs a random task stream; no collision, no lock overlap and no AGV
stalled past the stall limit may happen (docs/traffic.md, "Merges and crossings of
one-way lanes", "Waiting for a station on its AGV's way out", "Driving on").
``python -m tests.soak.floors`` runs many more seeds of the same drawing.
"""

from __future__ import annotations

import random
from typing import Any, ClassVar

import pytest
from hypothesis import example, given
from hypothesis import strategies as st

from agv_app.traffic.deadlock import merge_branches
from agv_app.vehicle import AgvController
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


# Up to twenty fleet runs of 500 simulated seconds with up to 8 AGVs (a few seconds
# of CPU each).
@pytest.mark.slow
@pytest.mark.timeout(900)
@FLEET_EXAMPLES
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
    assert figures["tasks_completed"] >= 1, f"{run}: nothing done"


# Two crowded draws (of 200) that locked with the merge rule alone: an AGV bound for a
# dock off an aisle waited on the north lane, or just after turning off it, and the
# dock's AGV had to leave along that lane.
_DOCK_WAITS = [
    FloorRun(one_way_floor(8, 12.0, {4: "n", 3: "s"}, middle=True, agvs=5), 6305, 1.0),
    FloorRun(one_way_floor(8, 12.0, {6: "n", 5: "n", 4: "s"}, middle=True, agvs=4), 2680, 1.0),
]


# Two fleets that lock (about 50 and 30 s of CPU) and two that do not (a few seconds).
@pytest.mark.slow
@pytest.mark.parametrize("run", _DOCK_WAITS)
def test_an_agv_waiting_for_a_dock_stays_off_the_way_out(run: FloorRun) -> None:
    # Found before the turn-off rule, which keeps these AGVs off the lane too.
    locked = run_floor(
        run,
        one_at_a_time=False,
        **FOUND_AT,
        vehicle=vehicle_with(keep_way_out=False, clear_turn_offs=False),
    )
    assert locked.summary()["deadlocks"] > 0
    figures = run_floor(run, one_at_a_time=False, **FOUND_AT).summary()
    assert figures["deadlocks"] == figures["collisions"] == figures["lock_overlaps"] == 0
    assert figures["tasks_completed"] > 2 * locked.summary()["tasks_completed"]


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


class _DrivingOn(AgvController):
    """An AGV component that records each time it drives on: (AGV, pose before, pose
    after, the destination it left, where it drives, where it comes back to)."""

    log: ClassVar[list[tuple[str, Any, Any, str | None, str | None, str | None]]] = []

    def _drive_on(self) -> bool:
        before, left = self.vehicle.pose(), self._dest
        drove = super()._drive_on()
        if drove:
            self.log.append(
                (self.node_id, before, self.vehicle.pose(), left, self._dest, self._resume)
            )
        return drove


# One fleet that locks (about 40 s of CPU) and one that does not (a few seconds).
@pytest.mark.slow
def test_an_agv_held_up_before_its_dock_drives_on_and_the_queue_behind_it_clears() -> None:
    # Found before the turn-off rule, which keeps the first AGV off the lane too.
    locked = run_floor(
        _QUEUED,
        one_at_a_time=False,
        **FOUND_AT,
        vehicle=vehicle_with(drive_on_after=None, clear_turn_offs=False),
    ).summary()
    assert locked["deadlocks"] > 0
    _DrivingOn.log.clear()
    fleet = run_floor(
        _QUEUED,
        one_at_a_time=False,
        **FOUND_AT,
        vehicle=vehicle_with(_DrivingOn, clear_turn_offs=False),
    )
    figures = fleet.summary()
    assert figures["deadlocks"] == figures["collisions"] == figures["lock_overlaps"] == 0
    assert figures["tasks_completed"] > 1.5 * locked["tasks_completed"]
    assert _DrivingOn.log, "no AGV drove on"
    assert figures["drive_ons"] == len(_DrivingOn.log)
    assert locked["drive_ons"] == 0
    parking = {s.point for s in _QUEUED.floor.layout.stations.values() if s.kind == "parking"}
    for agv, before, after, left, place, back in _DrivingOn.log:
        # It drives on from where it stands, to a parking place, and comes back.
        assert (after.x, after.y) == pytest.approx((before.x, before.y)), agv
        assert place in parking, agv
        assert back == left, agv


# The same floor locked with the default stations (each calls one AGV at a time and
# counts the AGVs bound to drop there), in a circle of two locks. An AGV bound for a
# dock off an aisle waited at the head of the aisle, just past its turn off the
# west-bound lane, the back of its hull 0.25 m into the lane, and the AGV behind it on
# the lane waited for that lock. After 60 s the first drove on, and its way on ran
# down the aisle and round the block, back west along the lane through the second's
# place: each waited on the other's lock, and neither stepped aside. Now the first
# stretch of an aisle after a turn off a lane is no resting place (docs/traffic.md,
# "Resting just past a turn off a lane").
@pytest.mark.slow
def test_the_queued_floor_no_longer_locks_just_past_a_turn_off_the_lane() -> None:
    # As found: before drop stations took one load at a time, which avoids it too.
    locked = run_floor(
        _QUEUED,
        wait_for_drop=False,
        **FOUND_AT,
        vehicle=vehicle_with(clear_turn_offs=False),
    ).summary()
    assert locked["deadlocks"] > 0
    figures = run_floor(_QUEUED, **FOUND_AT).summary()
    assert figures["collisions"] == figures["lock_overlaps"] == 0
    assert figures["deadlocks"] == 0, f"the longest wait {figures['max_wait']} s"
    assert figures["tasks_completed"] > locked["tasks_completed"]


class _Detouring(AgvController):
    """An AGV component that records each other way it takes: (AGV, the point it left
    the route at, the segment it was waiting to drive, its destination)."""

    log: ClassVar[list[tuple[str, str, str, str | None]]] = []

    def _detour(self) -> bool:
        route = self._route
        assert route is not None
        ahead = self._next_point(route)
        fork, waited_for, dest = route.points[ahead], route.segments[ahead], self._dest
        took = super()._detour()
        if took:
            assert self._route is not None
            assert waited_for not in self._route.segments
            self.log.append((self.node_id, fork, waited_for, dest))
        return took


# Seed 126 again, at the settings it was found at (today's, but every property
# republished every minute, not ten, and no session probed): a one-way loop four
# segments long (the north lane west from aisle 6, down aisle 5, the south lane east,
# up aisle 6), whose aisles are no-rest zones from end to end (a turn off the lane at
# the top, a merge at the bottom), fills with three AGVs, each waiting for the lock of
# the one ahead: the "full loop" of docs/traffic.md. The AGV that has waited a minute
# at the fork into aisle 5 takes the north lane on, round another aisle, and the loop
# opens.
@pytest.mark.slow
def test_a_full_loop_opens_when_an_agv_at_a_fork_takes_another_way() -> None:
    locked = run_floor(
        _QUEUED,
        republish=60.0,
        probes=False,
        station_nodes=True,
        max_open_tasks=None,
        vehicle=vehicle_with(detour_after=None),
    ).summary()
    assert locked["deadlocks"] >= 3
    _Detouring.log.clear()
    figures = run_floor(
        _QUEUED,
        republish=60.0,
        probes=False,
        station_nodes=True,
        max_open_tasks=None,
        vehicle=vehicle_with(_Detouring),
    ).summary()
    assert figures["deadlocks"] == figures["collisions"] == figures["lock_overlaps"] == 0
    assert figures["tasks_completed"] > 1.5 * locked["tasks_completed"]
    assert _Detouring.log, "no AGV took another way"
    assert figures["detours"] == len(_Detouring.log)
