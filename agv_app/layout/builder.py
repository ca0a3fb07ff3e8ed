"""A small builder for layouts drawn in code (the demo warehouse, generated warehouses)."""

from __future__ import annotations

import itertools

from agv_app.layout.elements import Point, Segment, Station, StationKind

__all__ = ["LayoutBuilder"]


class LayoutBuilder:
    """Collects the points, segments and stations of a layout drawn in code."""

    def __init__(self) -> None:
        self.points: list[Point] = []
        self.segments: list[Segment] = []
        self.stations: list[Station] = []

    def point(self, pid: str, x: float, y: float) -> str:
        """Add a point; returns its id."""
        self.points.append(Point(pid, x, y))
        return pid

    def chain(self, ids: list[str], *, bidirectional: bool = False) -> None:
        """Segments along ``ids`` in order (one-way unless ``bidirectional``)."""
        for a, b in itertools.pairwise(ids):
            self.segments.append(Segment(f"{a}>{b}", a, b, bidirectional=bidirectional))

    def merge(self, ids: list[str], box: str) -> None:
        """One-way along ``ids``, the last piece (from ``box`` on) a keep-clear box."""
        self.chain([*ids[:-1], box])
        end = ids[-1]
        self.segments.append(Segment(f"{box}>{end}", box, end, bidirectional=True))

    def spur(self, base: str, end: str, station: str, kind: StationKind) -> None:
        """A two-way spur from ``base`` to ``end``, with station ``station`` at its end."""
        self.segments.append(Segment(f"{base}>{end}", base, end, bidirectional=True))
        self.stations.append(Station(station, end, kind))
