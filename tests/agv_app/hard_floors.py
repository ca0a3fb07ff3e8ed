"""Random floors of the shapes that make AGVs wait long, drawn from a seed.

Three kinds (:mod:`agv_app.layout.shapes`), each at random sizes, with a random fleet
and load:

* ``crossing``: two-way lanes that cross at one point (three or four arms of 8 to 16 m),
  a station spur at each arm's end and one or two parking spurs a little further on;
* ``areas``: one two-way lane of 15 to 40 m between two dead-end areas, each with one
  or two stations and one or two parking spots, or the same lane with a lay-by halfway;
* ``halls``: two one-way halls joined by a two-way door of 8 to 20 m, stations off
  their north lanes and parking off their south lanes.

One drawing per kind (:data:`DRAWS`, from a ``random.Random``) serves the property tests
(``tests/agv_app/test_random_hard_layouts.py``) and the floor runner (``python -m
tests.soak.floors --kind crossing``), so a seed the runner reports is the same floor,
fleet and task stream everywhere. Every run is checked against the fleet's wait bound
(docs/traffic.md, "Bounded waits").
"""

from __future__ import annotations

import random
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from agv_app.fleet import Fleet, FleetConfig
from agv_app.fleet.parking import parking_capacity
from agv_app.layout import Layout
from agv_app.layout.shapes import crossing, halls, lane_between_areas, lay_by

__all__ = [
    "DRAWS",
    "HardFloor",
    "HardRun",
    "draw_areas_run",
    "draw_crossing_run",
    "draw_halls_run",
    "run_hard",
]


@dataclass(frozen=True, slots=True)
class HardFloor:
    """A drawn floor and how many AGVs run on it."""

    layout: Layout
    agvs: int
    shape: str

    def __repr__(self) -> str:
        return f"HardFloor({self.agvs} AGVs, {self.shape})"


@dataclass(frozen=True, slots=True)
class HardRun:
    """A floor, the fleet's seed and its load: one run of the property."""

    floor: HardFloor
    seed: int
    load: float


def _fleet(rng: random.Random, layout: Layout, most: int) -> int:
    return rng.randint(2, min(most, parking_capacity(layout)))


def draw_crossing_run(rng: random.Random) -> HardRun:
    """Three or four arms of 8 to 16 m, one or two parking spurs per arm, 2 to 6 AGVs,
    load 0.5 to 0.9."""
    arms = [rng.choice([8.0, 10.0, 12.0, 15.0, 16.0]) for _ in range(rng.choice([3, 4]))]
    further = rng.choice([3.0, 4.0, 5.0])
    parking = rng.choice([1, 2])
    layout = crossing(arms, further_m=further, parking=parking)
    shape = f"crossing arms {arms}, parking {parking} per arm {further:g} m on"
    floor = HardFloor(layout, _fleet(rng, layout, 6), shape)
    return HardRun(floor, rng.randint(0, 10_000), rng.choice([0.5, 0.7, 0.9]))


def draw_areas_run(rng: random.Random) -> HardRun:
    """A lane of 15 to 40 m (with a lay-by halfway on one draw in three), one or two
    stations and one or two parking spots per area, 2 to 4 AGVs, load 0.5 to 0.9."""
    lane = rng.choice([15.0, 20.0, 30.0, 40.0])
    stations = (rng.choice([1, 2]), rng.choice([1, 2]))
    parking = tuple(rng.choice([1, 2]) if n == 1 else 1 for n in stations)
    assert len(parking) == 2
    if lane >= 30.0 and rng.random() < 1 / 3:
        layout = lay_by(lane, stations=stations, parking=(parking[0], parking[1]))
        shape = f"lay-by lane {lane:g} m, stations {stations}, parking {parking}"
    else:
        layout = lane_between_areas(lane, stations=stations, parking=(parking[0], parking[1]))
        shape = f"lane {lane:g} m, stations {stations}, parking {parking}"
    floor = HardFloor(layout, _fleet(rng, layout, 4), shape)
    return HardRun(floor, rng.randint(0, 10_000), rng.choice([0.5, 0.7, 0.9]))


def draw_halls_run(rng: random.Random) -> HardRun:
    """Halls 15 to 25 m wide, a door of 8 to 20 m, two or three stations and parking
    spots per hall, 3 to 8 AGVs, load 0.5 to 0.9."""
    width = rng.choice([15.0, 20.0, 25.0])
    door = rng.choice([8.0, 12.0, 20.0])
    stations = (rng.choice([2, 3]), rng.choice([2, 3]))
    parking = (rng.choice([2, 3]), rng.choice([2, 3]))
    layout = halls(width, door_m=door, stations=stations, parking=parking)
    shape = f"halls {width:g} m, door {door:g} m, stations {stations}, parking {parking}"
    agvs = rng.randint(3, min(8, parking_capacity(layout)))
    floor = HardFloor(layout, agvs, shape)
    return HardRun(floor, rng.randint(0, 10_000), rng.choice([0.5, 0.7, 0.9]))


DRAWS: dict[str, Callable[[random.Random], HardRun]] = {
    "crossing": draw_crossing_run,
    "areas": draw_areas_run,
    "halls": draw_halls_run,
}
"""The kinds, and how a seed's run of each is drawn."""


def run_hard(run: HardRun, **options: Any) -> Fleet:
    """Tasks for 300 s, then 200 s more to finish them, at the drawn load; every step
    checked for safety (a collision or a lock overlap raises). ``options`` go to
    :class:`FleetConfig` where it has them (``one_at_a_time``, ``wait_for_drop``,
    ``wait_limit``), the rest to :class:`Fleet`."""
    fleet_options = {
        k: options.pop(k) for k in ("one_at_a_time", "wait_for_drop", "wait_limit") if k in options
    }
    cfg = FleetConfig(
        agvs=run.floor.agvs,
        seed=run.seed,
        load=run.load,
        load_of="fleet",  # past what the floor carries: AGVs queue
        task_until=300.0,
        fail_on_violation=True,
        **fleet_options,
    )
    fleet = Fleet(run.floor.layout, cfg, **options)
    fleet.run(500.0)
    return fleet
