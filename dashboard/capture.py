"""Reading a running fleet into ``FleetState``: one JSON-ready picture of an instant.

``capture`` reads the fleet (vehicles, clock, metrics) and takes the sessions and
per-node counters its caller collected from the nodes; the result shares nothing
mutable with the fleet, so the feed may keep it as long as it likes. Coordinates are
rounded to millimetres and headings to 1e-4 rad, which keeps float noise from producing
deltas. ``layout_json`` turns the floor plan into the JSON the page draws.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from agv_app.layout import Layout
from dashboard.source import FleetSource, VehicleView
from dashboard.stopping import (
    StopState,
    fleet_stop_asked,
    in_service_of,
    motion_of,
    stop_state,
)

__all__ = [
    "COORD_DIGITS",
    "JSON",
    "FleetState",
    "PolygonCache",
    "SessionRecord",
    "capture",
    "finite_or_none",
    "layout_json",
    "vehicle_json",
]

JSON = dict[str, Any]
"""A JSON object as Python sees it."""

COORD_DIGITS = 3
"""Digits kept of coordinates and times: millimetres are plenty on screen."""

_ANGLE_DIGITS = 4


@dataclass(frozen=True, slots=True)
class SessionRecord:
    """One live interaction session, as the feed and ``GET /api/sessions`` show it."""

    session_id: str
    node: str
    role: str
    participant_role: str
    members: tuple[str, ...]
    started_at: float
    definition: Any = None
    via_api: bool = False

    def as_json(self) -> JSON:
        """The session as a JSON object (``members`` sorted)."""
        return {
            "id": self.session_id,
            "node": self.node,
            "role": self.role,
            "participant_role": self.participant_role,
            "members": sorted(self.members),
            "started_at": round(self.started_at, COORD_DIGITS),
            "definition": self.definition,
            "via_api": self.via_api,
        }

    def started_over_http(self, role: str) -> SessionRecord:
        """This record for a session started through the REST API under ``role``."""
        return dataclasses.replace(self, role=role, via_api=True)


@dataclass(frozen=True, slots=True)
class FleetState:
    """Everything the page shows at one instant, already in JSON-ready form."""

    now: float
    paused: bool
    speed: float
    vehicles: Mapping[str, JSON] = field(default_factory=dict)
    sessions: Mapping[str, SessionRecord] = field(default_factory=dict)
    nodes: Mapping[str, JSON] = field(default_factory=dict)
    metrics: Mapping[str, float] = field(default_factory=dict)
    stop: StopState = "running"


def _xy(point: Sequence[float]) -> list[float]:
    return [round(float(point[0]), COORD_DIGITS), round(float(point[1]), COORD_DIGITS)]


def _polygon(polygon: Iterable[Sequence[float]]) -> list[list[float]]:
    return [_xy(p) for p in polygon]


def finite_or_none(value: float) -> float | None:
    """``value``, or None when it is NaN or infinite (JSON has neither; the page shows a
    dash for None)."""
    return value if math.isfinite(value) else None


class PolygonCache:
    """Remembers the JSON form of polygons the fleet hands over again and again.

    Locks change a few times a second while positions change every step, yet rounding
    every vertex of every projection 20 times a second costs tens of milliseconds at
    200 AGVs. Polygons given as tuples are looked up by value; an entry not used during
    the last ``keep`` captures is dropped, so the cache stays the size of what is live.

    Args:
        keep: captures an unused entry survives.
    """

    def __init__(self, *, keep: int = 2) -> None:
        self._entries: dict[Any, tuple[int, list[list[float]]]] = {}
        self._generation = 0
        self._keep = keep

    def __len__(self) -> int:
        """Number of polygons remembered."""
        return len(self._entries)

    def polygon(self, polygon: Iterable[Sequence[float]]) -> list[list[float]]:
        """The rounded JSON form of ``polygon``; the same list object while cached."""
        if not isinstance(polygon, tuple):
            return _polygon(polygon)
        try:
            hit = self._entries.get(polygon)
        except TypeError:  # a tuple holding lists is not hashable
            return _polygon(polygon)
        if hit is None:
            hit = (self._generation, _polygon(polygon))
        elif hit[0] != self._generation:
            hit = (self._generation, hit[1])
        self._entries[polygon] = hit
        return hit[1]

    def next_generation(self) -> None:
        """Start a new capture; forget what the last ``keep`` captures did not use."""
        self._generation += 1
        oldest = self._generation - self._keep
        stale = [k for k, (gen, _) in self._entries.items() if gen < oldest]
        for key in stale:
            del self._entries[key]


def vehicle_json(vehicle: VehicleView, cache: PolygonCache | None = None) -> JSON:
    """One vehicle as the feed's vehicle record (rounded, JSON-ready).

    Args:
        vehicle: the fleet's view of one AGV.
        cache: reuse the JSON form of polygons seen before.

    Returns:
        A dict with ``x, y, heading, length, width, status, task, hull, hull_length,
        locked, requested, speed, held, in_service, battery`` (the state of charge in
        percent; None: no battery model).
    """
    poly = _polygon if cache is None else cache.polygon
    speed, held = motion_of(vehicle)
    return {
        "x": round(float(vehicle.x), COORD_DIGITS),
        "y": round(float(vehicle.y), COORD_DIGITS),
        "heading": round(float(vehicle.heading_rad), _ANGLE_DIGITS),
        "length": float(vehicle.length_m),
        "width": float(vehicle.width_m),
        "status": str(vehicle.status),
        "task": None if vehicle.task_id is None else str(vehicle.task_id),
        "hull": _polygon(vehicle.hull),
        "hull_length": round(float(vehicle.hull_length), COORD_DIGITS),
        "locked": [poly(p) for p in vehicle.locked],
        "requested": [poly(p) for p in vehicle.requested],
        "speed": None if math.isnan(speed) else round(speed, 2),
        "held": held,
        "in_service": in_service_of(vehicle),
        "battery": _battery_of(vehicle),
    }


def _battery_of(vehicle: VehicleView) -> float | None:
    """The vehicle's state of charge, percent, rounded (None: it reports none)."""
    level = getattr(vehicle, "battery", None)
    if not isinstance(level, int | float) or isinstance(level, bool) or math.isnan(level):
        return None
    return round(float(level), 1)


def layout_json(layout: Layout) -> JSON:
    """The floor plan as JSON, with its bounding box for fitting it to the screen.

    Args:
        layout: the fleet's layout.

    Returns:
        ``{"name", "points", "segments", "stations", "bounds": [x0, y0, x1, y1]}``; a
        segment carries its drawn ``polyline``, a station the coordinates of its point.
    """
    points: list[JSON] = [
        {"id": p.id, "x": float(p.x), "y": float(p.y)}
        for p in sorted(layout.points.values(), key=lambda p: p.id)
    ]
    segments: list[JSON] = [
        {
            "id": s.id,
            "start": s.start,
            "end": s.end,
            "bidirectional": bool(s.bidirectional),
            "polyline": _polygon(layout.segment_coords(s.id)),
        }
        for s in sorted(layout.segments.values(), key=lambda s: s.id)
    ]
    stations: list[JSON] = []
    for st in sorted(layout.stations.values(), key=lambda s: s.id):
        at = layout.point(st.point)
        stations.append(
            {"id": st.id, "kind": st.kind, "point": st.point, "x": float(at.x), "y": float(at.y)}
        )
    x0, y0, x1, y1 = layout.bounds()
    return {
        "name": layout.name,
        "points": points,
        "segments": segments,
        "stations": stations,
        "bounds": [float(x0), float(y0), float(x1), float(y1)],
    }


def capture(
    source: FleetSource,
    *,
    sessions: Mapping[str, SessionRecord],
    nodes: Mapping[str, JSON],
    cache: PolygonCache | None = None,
) -> FleetState:
    """Read the fleet into a ``FleetState``.

    Args:
        source: the running fleet.
        sessions: live sessions by id (the caller collects them from the nodes).
        nodes: per-node counters by node id (``{"messages": .., "bytes": ..}`` and
            whatever else the node reports).
        cache: polygon cache kept between captures (its generation advances here).

    Returns:
        The state; it shares nothing mutable with the source.
    """
    if cache is not None:
        cache.next_generation()
    views = source.vehicles()
    vehicles = {v.id: vehicle_json(v, cache) for v in views}
    metrics = {str(k): float(v) for k, v in source.metrics().items()}
    return FleetState(
        now=float(source.now),
        paused=bool(source.paused),
        speed=float(source.speed),
        vehicles=vehicles,
        sessions=dict(sessions),
        nodes={k: dict(v) for k, v in nodes.items()},
        metrics=metrics,
        stop=stop_state(fleet_stop_asked(source), views),
    )
