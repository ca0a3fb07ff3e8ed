"""Small random two-way layouts, drawn from a seed: dead-end docks, crossings, spurs.

Each layout is a two-way main lane whose ends are dead-end docks, optionally crossed in
the middle by a second two-way lane whose ends are docks too, with two-way parking
spurs off the lane; 2 to 4 AGVs and a task every 20, 40 or 60 s. One drawing
(:func:`draw_two_way_run`, from a ``random.Random``) serves the property tests
(``tests/agv_app/test_random_layouts.py``, through hypothesis's seeded randoms) and the
seed runner (``python -m tests.soak.floors --kind two-way``).
"""

from __future__ import annotations

import random
from dataclasses import dataclass
from typing import Any

from agv_app.fleet import Fleet, FleetConfig
from agv_app.layout import Layout, Point, Segment, Station

__all__ = [
    "Floor",
    "TwoWayRun",
    "draw_two_way_run",
    "run_two_way",
    "single_track",
    "two_docks_one_lane",
]


@dataclass(frozen=True, slots=True)
class Floor:
    """A generated layout and how many AGVs it is meant for."""

    layout: Layout
    agvs: int

    def __repr__(self) -> str:
        segments = self.layout.segments.values()
        return f"Floor({self.agvs} AGVs, {' '.join(s.id for s in segments)}, gap {self.gap})"

    @property
    def gap(self) -> float:
        """Distance between neighbouring lane points."""
        return self.layout.point("m1").x


def two_docks_one_lane() -> Layout:
    """The finding's layout: docks at both ends of a two-way lane, parking off its middle.

    da <-> j <-> db along y = 0 (24 m), parking spurs j <-> pa (north), j <-> pb (south).
    """
    points = [
        Point("da", 0.0, 0.0),
        Point("j", 12.0, 0.0),
        Point("db", 24.0, 0.0),
        Point("pa", 12.0, 8.0),
        Point("pb", 12.0, -8.0),
    ]
    segments = [
        Segment("da-j", "da", "j", bidirectional=True),
        Segment("j-db", "j", "db", bidirectional=True),
        Segment("j-pa", "j", "pa", bidirectional=True),
        Segment("j-pb", "j", "pb", bidirectional=True),
    ]
    stations = [
        Station("dock-a", "da", "pickdrop"),
        Station("dock-b", "db", "pickdrop"),
        Station("park-a", "pa", "parking"),
        Station("park-b", "pb", "parking"),
    ]
    return Layout(points, segments, stations, name="two-docks-one-lane")


def single_track(lane_points: int, gap: float, parks: str, agvs: int = 4) -> Floor:
    """A two-way lane of ``lane_points`` points, docks at both ends, parking spurs
    named like ``p1n`` (lane point 1, north): the layouts :func:`draw_two_way_run` draws
    without a crossing."""
    points = [Point(f"m{i}", i * gap, 0.0) for i in range(lane_points)]
    segments = [
        Segment(f"m{i}-m{i + 1}", f"m{i}", f"m{i + 1}", bidirectional=True)
        for i in range(lane_points - 1)
    ]
    stations = [
        Station("dock-w", "m0", "pickdrop"),
        Station("dock-e", f"m{lane_points - 1}", "pickdrop"),
    ]
    for pid in parks.split():
        i, y = int(pid[1]), (8.0 if pid[2] == "n" else -8.0)
        points.append(Point(pid, i * gap, y))
        segments.append(Segment(f"m{i}-{pid}", f"m{i}", pid, bidirectional=True))
        stations.append(Station(f"park-{pid}", pid, "parking"))
    return Floor(Layout(points, segments, stations, name="single-track"), agvs)


@dataclass(frozen=True, slots=True)
class TwoWayRun:
    """A layout, the fleet's seed and its task interval: one run of the property."""

    floor: Floor
    seed: int
    interval: float


def draw_two_way_run(rng: random.Random) -> TwoWayRun:
    """A main lane of 3 to 5 points, maybe a crossing lane, parking spurs; 2 to 4 AGVs
    (no more than the parking spots); a task every 20, 40 or 60 s."""
    n = rng.randint(3, 5)
    gap = rng.choice([10.0, 12.0, 14.0])
    lane = [Point(f"m{i}", i * gap, 0.0) for i in range(n)]
    points = list(lane)
    segments = [
        Segment(f"m{i}-m{i + 1}", f"m{i}", f"m{i + 1}", bidirectional=True) for i in range(n - 1)
    ]
    stations = [Station("dock-w", "m0", "pickdrop"), Station("dock-e", f"m{n - 1}", "pickdrop")]
    inner = list(range(1, n - 1))
    crossing = rng.choice(inner) if rng.random() < 0.5 else None
    if crossing is not None:
        x = crossing * gap
        for name, y in (("cn", gap), ("cs", -gap)):
            points.append(Point(name, x, y))
            segments.append(
                Segment(f"m{crossing}-{name}", f"m{crossing}", name, bidirectional=True)
            )
            stations.append(Station(f"dock-{name}", name, "pickdrop"))
    spurs = [i for i in inner if i != crossing] or inner
    parks = 0
    for i in spurs:
        for side, y in (("n", 8.0), ("s", -8.0)):
            if parks >= 2 and rng.random() < 0.5:
                continue
            pid = f"p{i}{side}"
            # A spur off the crossing leaves it diagonally, between the lanes.
            points.append(Point(pid, i * gap + (6.0 if i == crossing else 0.0), y))
            segments.append(Segment(f"m{i}-{pid}", f"m{i}", pid, bidirectional=True))
            stations.append(Station(f"park-{pid}", pid, "parking"))
            parks += 1
    agvs = rng.randint(2, min(4, parks))
    floor = Floor(Layout(points, segments, stations, name="random"), agvs)
    return TwoWayRun(floor, rng.randint(0, 10_000), rng.choice([20.0, 40.0, 60.0]))


def run_two_way(
    run: TwoWayRun,
    *,
    one_at_a_time: bool = True,
    wait_for_drop: bool = True,
    **options: Any,
) -> Fleet:
    """Tasks for 200 s, then 200 s more to finish them; every step checked for safety
    (a collision or a lock overlap raises). ``one_at_a_time`` and ``wait_for_drop`` as
    in :class:`FleetConfig`; ``options`` go to :class:`Fleet`."""
    cfg = FleetConfig(
        agvs=run.floor.agvs,
        seed=run.seed,
        task_interval=run.interval,
        start_tasks=run.floor.agvs,
        task_until=200.0,
        one_at_a_time=one_at_a_time,
        wait_for_drop=wait_for_drop,
        fail_on_violation=True,
    )
    fleet = Fleet(run.floor.layout, cfg, **options)
    fleet.run(400.0)
    return fleet
