"""Where a route starts: the AGV's first lock is the hull it stands in."""

from __future__ import annotations

import math

import shapely

from agv_app.fleet import Fleet, FleetConfig
from agv_app.layout import Layout, Point, Segment


def corner() -> Layout:
    """A one-way lane north to the corner C, then one-way west: a right angle."""
    points = [Point("S", 58.0, 20.0), Point("C", 58.0, 36.5), Point("W", 40.0, 36.5)]
    segments = [Segment("S-C", "S", "C"), Segment("C-W", "C", "W")]
    return Layout(points, segments, name="corner")


def test_an_agv_leaving_a_right_angle_corner_locks_the_hull_it_stands_in() -> None:
    """Seen on the demo warehouse (its corners are exact right angles): the route's
    short lead piece came out a hair shorter than its start, so the AGV started past
    the corner, its first lock was the hull already turned west, and the turn on the
    spot was never requested (a lock overlap with an AGV beside the corner)."""
    cfg = FleetConfig(agvs=1, seed=1, task_interval=1e9, start_tasks=0, fail_on_violation=True)
    fleet = Fleet(corner(), cfg, homes=["W"], starts=["C"], headings=[math.pi / 2])
    agv = fleet.agvs["agv-01"]
    standing = agv.vehicle.hull()
    fleet.step()
    assert agv.phase == "to_home"
    first = agv.book.locks()[0].area
    assert shapely.difference(standing.geom, first.geom).area < 1e-6
    assert agv.vehicle.pose().heading_rad == math.pi / 2
