"""Deadlock freedom on random one-way floors: loops, aisles that merge, crossings.

Each floor is a counter-clockwise one-way ring (south lane east, east column north,
north lane west, west column south) with one to three one-way aisles between the
south and the north lane, each running north or south, and optionally a one-way
middle lane east from the west column to the east column that crosses every aisle.
No merge has a keep-clear box: aisles turn into the lanes they join, the middle lane
turns into the east column, and the aisles cross the middle lane. Stations stand on
two-way spurs off the aisles and the north lane, parking spurs off the south lane, so
AGVs stop in the aisles and queue into the lanes. A random fleet
runs a random task stream; no collision, no lock overlap and no AGV stalled past the
stall limit may happen (docs/traffic.md, "Merges and crossings of one-way lanes").
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, ClassVar

import pytest
from hypothesis import example, given
from hypothesis import strategies as st

from agv_app.fleet import Fleet, FleetConfig
from agv_app.layout import Layout
from agv_app.layout.builder import LayoutBuilder
from agv_app.traffic.deadlock import merge_branches
from agv_app.vehicle import AgvController
from tests.agv_app.test_random_layouts import FLEET_EXAMPLES
from tests.agv_app.traffic.test_merges import without_clear_merges

_STEP = 5.0
_SPUR = 2.5


@dataclass(frozen=True, slots=True)
class OneWayFloor:
    """A generated one-way floor and how many AGVs it is meant for."""

    layout: Layout
    agvs: int
    aisles: tuple[tuple[int, str], ...]
    middle: bool

    def __repr__(self) -> str:
        width = max(p.x for p in self.layout.points.values())
        return (
            f"OneWayFloor({self.agvs} AGVs, {width:g} m wide, aisles {self.aisles}, "
            f"middle lane {self.middle})"
        )


def one_way_floor(
    columns: int, height: float, aisles: dict[int, str], *, middle: bool, agvs: int
) -> OneWayFloor:
    """The floor ``columns`` steps of 5 m wide and ``height`` m high; ``aisles`` maps a
    column index to ``"n"`` or ``"s"``; docks and parking fill the other columns."""
    b = LayoutBuilder()
    levels = [0.0, height / 2, height] if middle else [0.0, height]
    for k in (0, columns):
        column = [b.point(f"c{k}y{j}", k * _STEP, y) for j, y in enumerate(levels)]
        b.chain(column if k else column[::-1])  # the east column north, the west south
    for name, j, eastward in (("s", 0, True), ("n", len(levels) - 1, False), ("m", 1, True)):
        if name == "m" and not middle:
            continue
        inner = [b.point(f"{name}{k}", k * _STEP, levels[j]) for k in range(1, columns)]
        lane = [f"c0y{j}", *inner, f"c{columns}y{j}"]
        b.chain(lane if eastward else lane[::-1])
    for k, way in aisles.items():
        # A station spur east off each aisle, a quarter of the way from either end.
        column = [f"s{k}", f"a{k}s", *([f"m{k}"] if middle else []), f"a{k}n", f"n{k}"]
        for end, y in (("s", height / 4), ("n", 3 * height / 4)):
            b.point(f"a{k}{end}", k * _STEP, y)
            station = b.point(f"a{k}{end}x", k * _STEP + _SPUR, y)
            b.spur(f"a{k}{end}", station, f"aisle-{k}{end}", "pickdrop")
        b.chain(column if way == "n" else column[::-1])
    for k in range(1, columns):
        if k not in aisles:
            b.spur(f"n{k}", b.point(f"d{k}", k * _STEP, height + _SPUR), f"dock-{k}", "pickdrop")
            b.spur(f"s{k}", b.point(f"p{k}", k * _STEP, -_SPUR), f"park-{k}", "parking")
    layout = Layout(b.points, b.segments, b.stations, name="one-way")
    return OneWayFloor(layout, agvs, tuple(sorted(aisles.items())), middle)


@st.composite
def one_way_floors(draw: st.DrawFn) -> OneWayFloor:
    """A ring 40 to 50 m wide and 12 to 20 m high, one to three aisles, maybe a middle
    lane, and as many AGVs as the floor parks or one fewer: crowded enough that,
    without the merge rule, about one draw in eight locks."""
    columns = draw(st.integers(8, 10))
    height = draw(st.sampled_from([12.0, 16.0, 20.0]))
    inner = list(range(2, columns - 1))
    chosen = draw(st.lists(st.sampled_from(inner), min_size=1, max_size=3, unique=True))
    aisles = {k: draw(st.sampled_from(["n", "s"])) for k in chosen}
    middle = draw(st.booleans())
    parking = columns - 1 - len(aisles)
    agvs = draw(st.integers(max(3, parking - 1), parking))
    return one_way_floor(columns, height, aisles, middle=middle, agvs=agvs)


def _run(floor: OneWayFloor, seed: int, load: float, **options: Any) -> Fleet:
    """Tasks for 300 s, then 200 s more to finish them; every step checked for safety."""
    cfg = FleetConfig(
        agvs=floor.agvs, seed=seed, load=load, task_until=300.0, fail_on_violation=True
    )
    fleet = Fleet(floor.layout, cfg, **options)
    fleet.run(500.0)
    return fleet


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
_LOCKED = [
    (one_way_floor(9, 16.0, {3: "s", 5: "s", 7: "n"}, middle=True, agvs=5), 9755, 0.9),
    (one_way_floor(8, 16.0, {5: "s"}, middle=True, agvs=6), 625, 1.0),
    (one_way_floor(9, 12.0, {4: "n", 5: "s", 6: "n"}, middle=True, agvs=5), 1269, 1.0),
    (one_way_floor(8, 12.0, {3: "n", 5: "n"}, middle=True, agvs=5), 2910, 0.9),
]


@pytest.mark.slow
def test_without_the_rule_these_floors_lock() -> None:
    """What the examples below replay: each of them locks without the rule."""
    for floor, seed, load in _LOCKED:
        fleet = _run(floor, seed, load, vehicle=without_clear_merges)
        assert fleet.summary()["deadlocks"] > 0, f"seed {seed}, load {load}, {floor}"


# Up to twenty fleet runs of 500 simulated seconds with up to 8 AGVs (a few seconds
# of CPU each).
@pytest.mark.slow
@pytest.mark.timeout(900)
@FLEET_EXAMPLES
@given(
    floor=one_way_floors(),
    seed=st.integers(0, 10_000),
    load=st.sampled_from([0.7, 0.9, 1.0]),
)
@example(*_LOCKED[0])
@example(*_LOCKED[1])
@example(*_LOCKED[2])
@example(*_LOCKED[3])
def test_random_one_way_floors_never_stall(floor: OneWayFloor, seed: int, load: float) -> None:
    fleet = _run(floor, seed, load)
    figures = fleet.summary()
    stuck = {a: (agv.phase, agv.point) for a, agv in fleet.agvs.items() if agv.stalled}
    assert figures["collisions"] == figures["lock_overlaps"] == 0
    assert figures["deadlocks"] == 0, f"seed {seed}, load {load}, {floor}: stalled {stuck}"
    assert figures["tasks_completed"] >= 1, f"seed {seed}, load {load}, {floor}: nothing done"


# Two crowded draws (of 200) that locked with the merge rule alone: an AGV bound for a
# dock off an aisle waited on the north lane, or just after turning off it, and the
# dock's AGV had to leave along that lane.
_DOCK_WAITS = [
    (one_way_floor(8, 12.0, {4: "n", 3: "s"}, middle=True, agvs=5), 6305, 1.0),
    (one_way_floor(8, 12.0, {6: "n", 5: "n", 4: "s"}, middle=True, agvs=4), 2680, 1.0),
]


def without_keep_way_out(*args: Any, config: Any, **kwargs: Any) -> AgvController:
    """An AGV component built as the fleet asks, but without ``keep_way_out``."""
    return AgvController(*args, config=dataclasses.replace(config, keep_way_out=False), **kwargs)


# Two fleets that lock (about 50 and 30 s of CPU) and two that do not (a few seconds).
@pytest.mark.slow
@pytest.mark.timeout(300)
@pytest.mark.parametrize(("floor", "seed", "load"), _DOCK_WAITS)
def test_an_agv_waiting_for_a_dock_stays_off_the_way_out(
    floor: OneWayFloor, seed: int, load: float
) -> None:
    locked = _run(floor, seed, load, vehicle=without_keep_way_out).summary()
    assert locked["deadlocks"] > 0
    figures = _run(floor, seed, load).summary()
    assert figures["deadlocks"] == figures["collisions"] == figures["lock_overlaps"] == 0
    assert figures["tasks_completed"] > 2 * locked["tasks_completed"]


# A draw (of 300) that locked with the way-out rule: an AGV waits for a dock off an
# aisle on the north lane, clear of the dock's way out, and three AGVs bound elsewhere
# queue behind it; the dock's AGV leaves round a short loop (down its aisle, along the
# middle lane, up the next aisle) whose first request reaches onto the north lane, into
# the queue.
_QUEUED = (one_way_floor(10, 12.0, {6: "n", 5: "s", 3: "s"}, middle=True, agvs=5), 7976, 0.7)


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


def without_driving_on(*args: Any, config: Any, **kwargs: Any) -> AgvController:
    """An AGV component built as the fleet asks, but that never drives on."""
    return AgvController(*args, config=dataclasses.replace(config, drive_on_after=None), **kwargs)


# One fleet that locks (about 40 s of CPU) and one that does not (a few seconds).
@pytest.mark.slow
@pytest.mark.timeout(300)
def test_an_agv_held_up_before_its_dock_drives_on_and_the_queue_behind_it_clears() -> None:
    locked = _run(*_QUEUED, vehicle=without_driving_on).summary()
    assert locked["deadlocks"] > 0
    _DrivingOn.log.clear()
    fleet = _run(*_QUEUED, vehicle=_DrivingOn)
    figures = fleet.summary()
    assert figures["deadlocks"] == figures["collisions"] == figures["lock_overlaps"] == 0
    assert figures["tasks_completed"] > 1.5 * locked["tasks_completed"]
    assert _DrivingOn.log, "no AGV drove on"
    parking = {s.point for s in _QUEUED[0].layout.stations.values() if s.kind == "parking"}
    for agv, before, after, left, place, back in _DrivingOn.log:
        # It drives on from where it stands, to a parking place, and comes back.
        assert (after.x, after.y) == pytest.approx((before.x, before.y)), agv
        assert place in parking, agv
        assert back == left, agv
