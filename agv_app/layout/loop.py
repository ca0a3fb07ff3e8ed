"""A long one-way loop: a floor much longer than an AGV's interest radius.

Two lanes 20 m apart, joined at both ends into one counter-clockwise loop (east along
``y = 0``, west along ``y = 20``). Parking spurs leave the south lane northwards every
5 m, station spurs leave the north lane southwards every 20 m (pick, drop and pickdrop
in turn). Every spur is 2.5 m long and two-way, a dead end; the lanes are one-way, so
no two AGVs ever meet head-on. The demo warehouse fits inside one AGV's interest radius;
this floor does not, which is where scoped dissemination leaves nodes out
(tests/agv_app/traffic/test_interest_radius.py, bench/fleet_bandwidth.py).
"""

from __future__ import annotations

import itertools

from agv_app.layout.elements import Point, Segment, Station, StationKind
from agv_app.layout.graph import Layout

__all__ = ["long_loop"]

_STEP_M = 5.0
_WIDTH_M = 20.0
_SPUR_M = 2.5
_STATION_EVERY = 4  # spurs
_KINDS: tuple[StationKind, ...] = ("pick", "drop", "pickdrop")


def long_loop(length_m: float = 300.0) -> Layout:
    """The loop, ``length_m`` long (rounded down to 5 m, at least 20 m).

    Raises:
        ValueError: ``length_m`` is below 20.
    """
    if not length_m >= 4 * _STEP_M:
        raise ValueError(f"length_m must be at least {4 * _STEP_M:g}, got {length_m!r}")
    xs = [_STEP_M * k for k in range(int(length_m / _STEP_M) + 1)]
    south = [f"s{k}" for k in range(len(xs))]
    north = [f"n{k}" for k in range(len(xs))]
    points = [Point(p, x, 0.0) for p, x in zip(south, xs, strict=True)]
    points += [Point(p, x, _WIDTH_M) for p, x in zip(north, xs, strict=True)]
    lane = [*south, *reversed(north), south[0]]
    segments = [Segment(f"{a}>{b}", a, b) for a, b in itertools.pairwise(lane)]
    stations: list[Station] = []
    for k in range(1, len(xs) - 1):
        points.append(Point(f"park{k}", xs[k], _SPUR_M))
        segments.append(Segment(f"s{k}-park{k}", f"s{k}", f"park{k}", bidirectional=True))
        stations.append(Station(f"park-{k}", f"park{k}", "parking"))
        if k % _STATION_EVERY == 0:
            points.append(Point(f"dock{k}", xs[k], _WIDTH_M - _SPUR_M))
            segments.append(Segment(f"n{k}-dock{k}", f"n{k}", f"dock{k}", bidirectional=True))
            kind = _KINDS[(k // _STATION_EVERY) % len(_KINDS)]
            stations.append(Station(f"dock-{k}", f"dock{k}", kind))
    return Layout(points, segments, stations, name=f"long-loop-{xs[-1]:g}m")
