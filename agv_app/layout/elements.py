"""The elements of a floor plan: points, segments, stations, routes, and the errors.

Errors (one base class; messages name the offending element)::

    LayoutError (ValueError)        a layout is inconsistent, or a query is impossible
     +-- LayoutFileError            a file cannot be read or parsed; .where says where
     +-- NoRouteError               no directed route between two points
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, get_args

from agv_app.geometry import XY, Polyline

__all__ = [
    "STATION_KINDS",
    "LayoutError",
    "LayoutFileError",
    "NoRouteError",
    "PassingExtent",
    "Point",
    "Route",
    "Segment",
    "Station",
    "StationKind",
]

StationKind = Literal["pick", "drop", "pickdrop", "parking", "charging"]
"""What a station is for."""

STATION_KINDS: tuple[StationKind, ...] = get_args(StationKind)
"""All station kinds, in a fixed order."""


class LayoutError(ValueError):
    """A layout is inconsistent, or a query on it cannot be answered."""


class LayoutFileError(LayoutError):
    """A layout file cannot be read or parsed.

    Attributes:
        where: location in the file: a JSON path (``$.segments[3].start``) or
            ``line N`` for XML; ``""`` if unknown.
    """

    def __init__(self, message: str, *, where: str = "") -> None:
        super().__init__(f"{where}: {message}" if where else message)
        self.where = where


class NoRouteError(LayoutError):
    """There is no directed route between two points."""


@dataclass(frozen=True, slots=True)
class Point:
    """A named position on the floor.

    Attributes:
        id: unique among points.
        x: metres.
        y: metres.
        passing: force this point to count as a passing place.
    """

    id: str
    x: float
    y: float
    passing: bool = False

    @property
    def xy(self) -> XY:
        """``(x, y)``."""
        return (self.x, self.y)


@dataclass(frozen=True, slots=True)
class Segment:
    """A drivable path between two points.

    Attributes:
        id: unique among segments.
        start: point id where it begins.
        end: point id where it ends.
        bidirectional: drivable ``end -> start`` too.
        via: intermediate vertices ``(x, y)`` from ``start`` to ``end`` (curves).
    """

    id: str
    start: str
    end: str
    bidirectional: bool = False
    via: tuple[XY, ...] = ()


@dataclass(frozen=True, slots=True)
class Station:
    """A place where vehicles work or wait.

    Attributes:
        id: unique among stations.
        point: the point a vehicle stands on to serve it.
        kind: one of :data:`STATION_KINDS`.
    """

    id: str
    point: str
    kind: StationKind = "pickdrop"


@dataclass(frozen=True, slots=True)
class Route:
    """A drivable sequence of points, with its geometry.

    Attributes:
        points: point ids, from start to destination (one point: already there).
        segments: segment ids between consecutive points (one fewer).
        polyline: the path driven, including ``via`` vertices.
        offsets: arc length along ``polyline`` at each entry of ``points``.
    """

    points: tuple[str, ...]
    segments: tuple[str, ...]
    polyline: Polyline
    offsets: tuple[float, ...]

    @property
    def length(self) -> float:
        """Total length in metres."""
        return self.offsets[-1]

    @property
    def start(self) -> str:
        """First point id."""
        return self.points[0]

    @property
    def end(self) -> str:
        """Destination point id."""
        return self.points[-1]

    def index_at(self, s: float) -> int:
        """Index of the last route point at or before arc length ``s``."""
        lo, hi = 0, len(self.offsets) - 1
        while lo < hi:
            mid = (lo + hi + 1) // 2
            if self.offsets[mid] <= s:
                lo = mid
            else:
                hi = mid - 1
        return lo


@dataclass(frozen=True, slots=True)
class PassingExtent:
    """How far a lock request entering a route's segment must reach.

    Attributes:
        index: route point index where the request may end.
        s: arc length of that point along the route.
        bidirectional: whether the entered segment is bidirectional (if not, the
            extent is just the end of that segment).
    """

    index: int
    s: float
    bidirectional: bool
