"""Random one-way floors, drawn from a seed: loops, aisles that merge, crossings.

Each floor is a counter-clockwise one-way ring (south lane east, east column north,
north lane west, west column south) with one to three one-way aisles between the
south and the north lane, each running north or south, and optionally a one-way
middle lane east from the west column to the east column that crosses every aisle.
No merge has a keep-clear box: aisles turn into the lanes they join, the middle lane
turns into the east column, and the aisles cross the middle lane. Stations stand on
two-way spurs off the aisles and the north lane, parking spurs off the south lane, so
AGVs stop in the aisles and queue into the lanes.

One drawing (:func:`draw_floor_run`, from a ``random.Random``) serves the property
test (``tests/agv_app/test_random_one_way_floors.py``, through hypothesis's seeded
randoms) and the seed runner (``python -m tests.soak.floors``), so a seed the runner
reports is the same floor, fleet and task stream everywhere.
"""

from __future__ import annotations

import random
from dataclasses import dataclass
from typing import Any

from agv_app.fleet import Fleet, FleetConfig
from agv_app.fleet.liveness import REST_BEAT_S
from agv_app.layout import Layout
from agv_app.layout.builder import LayoutBuilder
from agv_app.vehicle.controller import DEFAULT_ADVANCE_M

__all__ = [
    "FloorRun",
    "OneWayFloor",
    "draw_floor_run",
    "one_way_floor",
    "run_floor",
]

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


@dataclass(frozen=True, slots=True)
class FloorRun:
    """A floor, the fleet's seed and its load: one run of the property."""

    floor: OneWayFloor
    seed: int
    load: float


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


def draw_floor_run(rng: random.Random) -> FloorRun:
    """A ring 40 to 50 m wide and 12 to 20 m high, one to three aisles, maybe a middle
    lane, and as many AGVs as the floor parks or one fewer, at load 0.7 to 1.0: crowded
    enough that, without the merge rule, about one draw in eight locks."""
    columns = rng.randint(8, 10)
    height = rng.choice([12.0, 16.0, 20.0])
    chosen = rng.sample(range(2, columns - 1), rng.randint(1, 3))
    aisles = {k: rng.choice(["n", "s"]) for k in chosen}
    middle = rng.random() < 0.5
    parking = columns - 1 - len(aisles)
    agvs = rng.randint(max(3, parking - 1), parking)
    floor = one_way_floor(columns, height, aisles, middle=middle, agvs=agvs)
    return FloorRun(floor, rng.randint(0, 10_000), rng.choice([0.7, 0.9, 1.0]))


def run_floor(
    run: FloorRun,
    *,
    one_at_a_time: bool = True,
    wait_for_drop: bool = True,
    advance_m: float = DEFAULT_ADVANCE_M,
    rest_beat: float | None = REST_BEAT_S,
    republish: float | None = None,
    probes: bool = True,
    station_nodes: bool = False,
    max_open_tasks: int | str | None = "auto",
    **options: Any,
) -> Fleet:
    """Tasks for 300 s, then 200 s more to finish them; every step checked for safety
    (a collision or a lock overlap raises). ``one_at_a_time``, ``wait_for_drop``,
    ``advance_m``, ``rest_beat``, ``republish``, ``probes``, ``station_nodes`` and
    ``max_open_tasks`` as in :class:`FleetConfig`; ``options`` go to :class:`Fleet`."""
    cfg = FleetConfig(
        agvs=run.floor.agvs,
        seed=run.seed,
        load=run.load,
        load_of="fleet",  # past what the floor carries: AGVs queue
        task_until=300.0,
        one_at_a_time=one_at_a_time,
        wait_for_drop=wait_for_drop,
        advance_m=advance_m,
        rest_beat=rest_beat,
        republish=republish,
        probes=probes,
        station_nodes=station_nodes,
        max_open_tasks=max_open_tasks,
        fail_on_violation=True,
    )
    fleet = Fleet(run.floor.layout, cfg, **options)
    fleet.run(500.0)
    return fleet
