"""Deadlock freedom on small random layouts: two-way lanes, dead-end docks, crossings.

Each layout is a two-way main lane whose ends are dead-end docks, optionally crossed in
the middle by a second two-way lane whose ends are docks too, with two-way parking
spurs off the lane. A random fleet of 2 to 4 AGVs runs a random task stream on it; the
run must have no collision, no lock overlap and no AGV stalled past the stall limit.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import pytest
from hypothesis import HealthCheck, Phase, example, given, settings
from hypothesis import strategies as st

from agv_app.fleet import Fleet, FleetConfig, ParkingPlan
from agv_app.layout import Layout, Point, Segment, Station
from agv_app.vehicle import VehicleSpec

_CI = bool(os.environ.get("CI"))


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


def test_two_agvs_at_the_two_docks_swap_them() -> None:
    """Each AGV stands at one dock and must carry a load to the other one."""
    layout = two_docks_one_lane()
    cfg = FleetConfig(agvs=2, seed=1, task_interval=1e9, start_tasks=0, fail_on_violation=True)
    fleet = Fleet(layout, cfg, homes=["pa", "pb"], starts=["da", "db"])
    fleet.create_task("dock-a", "dock-b")
    fleet.create_task("dock-b", "dock-a")
    fleet.run(240.0)
    figures = fleet.summary()
    assert figures["deadlocks"] == 0
    assert figures["tasks_completed"] == figures["tasks_created"] == 2
    assert figures["collisions"] == figures["lock_overlaps"] == 0
    # One of them (or both) backed off to its parking spot to let the other through.
    assert figures["yields"] >= 1
    assert figures["drive_ons"] == 0


def single_track(lane_points: int, gap: float, parks: str, agvs: int = 4) -> Floor:
    """A two-way lane of ``lane_points`` points, docks at both ends, parking spurs
    named like ``p1n`` (lane point 1, north): the layouts ``floors`` draws without a
    crossing."""
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


# Seeds where, before the longest-waiting request won its conflicts, one AGV lost a
# single track to newer requests for over 180 s (docs/traffic.md, "Fairness").
_STARVED = [
    (single_track(4, 14.0, "p1n p1s p2n p2s"), 327, 60.0),
    (single_track(5, 12.0, "p1n p1s p2n p3n p3s"), 4559, 20.0),
    (single_track(5, 10.0, "p1n p1s p2n p3n p3s"), 3055, 60.0),
    (single_track(5, 12.0, "p1n p1s p2n p2s p3s"), 1012, 60.0),
]


@st.composite
def floors(draw: st.DrawFn) -> Floor:
    """A main lane of 3 to 5 points, optionally a crossing lane, parking spurs."""
    n = draw(st.integers(3, 5))
    gap = draw(st.sampled_from([10.0, 12.0, 14.0]))
    lane = [Point(f"m{i}", i * gap, 0.0) for i in range(n)]
    points = list(lane)
    segments = [
        Segment(f"m{i}-m{i + 1}", f"m{i}", f"m{i + 1}", bidirectional=True) for i in range(n - 1)
    ]
    stations = [Station("dock-w", "m0", "pickdrop"), Station("dock-e", f"m{n - 1}", "pickdrop")]
    inner = list(range(1, n - 1))
    crossing = draw(st.sampled_from(inner)) if draw(st.booleans()) else None
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
            if parks >= 2 and not draw(st.booleans()):
                continue
            pid = f"p{i}{side}"
            # A spur off the crossing leaves it diagonally, between the lanes.
            points.append(Point(pid, i * gap + (6.0 if i == crossing else 0.0), y))
            segments.append(Segment(f"m{i}-{pid}", f"m{i}", pid, bidirectional=True))
            stations.append(Station(f"park-{pid}", pid, "parking"))
            parks += 1
    agvs = draw(st.integers(2, min(4, parks)))
    return Floor(Layout(points, segments, stations, name="random"), agvs)


# Settings for properties whose examples are fleet runs (here and in the one-way floors).
FLEET_EXAMPLES = settings(
    max_examples=20,
    deadline=None,
    derandomize=_CI,
    # A failing run is reported as drawn: shrinking a fleet run costs minutes.
    phases=(Phase.explicit, Phase.reuse, Phase.generate),
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)


def _run(floor: Floor, seed: int, interval: float) -> Fleet:
    """Tasks for 200 s, then 200 s more to finish them; every step checked for safety."""
    cfg = FleetConfig(
        agvs=floor.agvs,
        seed=seed,
        task_interval=interval,
        start_tasks=floor.agvs,
        task_until=200.0,
        fail_on_violation=True,
    )
    fleet = Fleet(floor.layout, cfg)
    fleet.run(400.0)
    return fleet


# Twenty fleet runs of 400 simulated seconds each (about a minute on a quiet core): the
# suite's 120 s guard against hangs is too tight for them on a busy machine.
@pytest.mark.slow
@pytest.mark.timeout(900)
@FLEET_EXAMPLES
@given(floor=floors(), seed=st.integers(0, 10_000), interval=st.sampled_from([20.0, 40.0, 60.0]))
def test_random_layouts_stay_safe_and_get_work_done(
    floor: Floor, seed: int, interval: float
) -> None:
    fleet = _run(floor, seed, interval)
    figures = fleet.summary()
    assert figures["collisions"] == figures["lock_overlaps"] == 0
    assert figures["tasks_completed"] >= 1, f"seed {seed}, {floor}: nothing done"


# Twenty fleet runs of 400 simulated seconds each (about a minute on a quiet core): the
# suite's 120 s guard against hangs is too tight for them on a busy machine.
@pytest.mark.slow
@pytest.mark.timeout(900)
@FLEET_EXAMPLES
@given(floor=floors(), seed=st.integers(0, 10_000), interval=st.sampled_from([20.0, 40.0, 60.0]))
@example(*_STARVED[0])
@example(*_STARVED[1])
@example(*_STARVED[2])
@example(*_STARVED[3])
def test_random_layouts_never_stall(floor: Floor, seed: int, interval: float) -> None:
    fleet = _run(floor, seed, interval)
    stuck = {a: (agv.phase, agv.point) for a, agv in fleet.agvs.items() if agv.stalled}
    assert fleet.summary()["deadlocks"] == 0, f"seed {seed}, {floor}: stalled {stuck}"


def test_spare_rest_points_are_never_on_a_two_way_lane() -> None:
    """Idle AGVs moved out of the way, and yielding ones, wait at dead ends only here."""
    layout = two_docks_one_lane()
    plan = ParkingPlan(layout, VehicleSpec(2.0, 1.0), 2)
    plan.claim("agv-1", "pa")
    plan.claim("agv-2", "pb")
    # The junction j would be a hull diagonal from everything, but it is on the lane.
    assert plan.relocate("agv-1", "pa", at="da") is None
