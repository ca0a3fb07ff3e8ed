"""What a fleet shows the dashboard: one :class:`VehicleState` per AGV, and its observer.

Both fleets implement the dashboard's ``FleetSource`` protocol structurally (the
dashboard imports us, never the other way round) and describe their AGVs alike.
"""

from __future__ import annotations

from dataclasses import dataclass

from agv_app.geometry import XY, Area

__all__ = ["OBSERVER_ID", "VehicleState", "area_rings"]

OBSERVER_ID = "observer"
"""Node id of the dashboard's observer node (no position; it hears every node)."""


@dataclass(frozen=True, slots=True)
class VehicleState:
    """One AGV as the dashboard sees it (a ``VehicleView``)."""

    id: str
    x: float
    y: float
    heading_rad: float
    length_m: float
    width_m: float
    status: str
    task_id: str | None
    hull: tuple[XY, ...]
    hull_length: float
    locked: tuple[tuple[XY, ...], ...]
    requested: tuple[tuple[XY, ...], ...]
    speed_m_s: float = 0.0
    """Its speed as it last reported it."""
    held: bool = False
    """Whether it holds for an operator's stop (as it reports it)."""
    in_service: bool = True
    """Whether it takes tasks (as it reports it)."""
    battery: float | None = None
    """Its state of charge, percent (None: no battery model)."""


def area_rings(area: Area | None) -> tuple[tuple[XY, ...], ...]:
    """The exterior ring of each polygon of ``area``, without the closing vertex."""
    if area is None or area.is_empty:
        return ()
    geom = area.geom
    parts = list(geom.geoms) if geom.geom_type == "MultiPolygon" else [geom]
    return tuple(
        tuple((float(x), float(y)) for x, y in list(p.exterior.coords)[:-1]) for p in parts
    )
