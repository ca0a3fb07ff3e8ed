"""What a mesh fleet's observer holds of the AGVs: which nodes are AGVs, each one's
properties with its display over them (:mod:`agv_app.fleet.display_feed`), and the route
an AGV last reported.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from agv_app.fleet.display_feed import DisplayCollector
from agv_app.fleet.view import VehicleState
from agv_app.geometry import XY
from agv_app.protocol import AGV_KIND
from objectplaces.mesh import MeshNode

__all__ = ["agv_ids_heard", "agv_view", "agv_views", "is_agv", "reported_route"]


def is_agv(props: Mapping[str, Any]) -> bool:
    """Whether properties the observer holds are an AGV's, with a position to draw."""
    return props.get("kind") == AGV_KIND and isinstance(props.get("position"), tuple)


def agv_ids_heard(observer: MeshNode | None) -> set[str]:
    """Ids of the AGVs the observer hears (no display merged: a count, a check)."""
    if observer is None or observer.closed:
        return set()
    return {n for n, props in observer.view().items() if is_agv(props)}


def agv_views(
    observer: MeshNode | None, display: DisplayCollector
) -> list[tuple[str, Mapping[str, Any]]]:
    """Every AGV the observer hears, by id, its display over its properties."""
    if observer is None or observer.closed:
        return []
    view, shown = observer.view(), display.shown
    return [(n, shown(n, view[n])) for n in sorted(view) if is_agv(view[n])]


def agv_view(
    observer: MeshNode | None, display: DisplayCollector, agv_id: str
) -> Mapping[str, Any] | None:
    """One AGV as ``agv_views`` gives it, without merging the others (None: not heard)."""
    if observer is None or observer.closed:
        return None
    props = observer.view().get(agv_id)
    if props is None or not is_agv(props):
        return None
    return display.shown(agv_id, props)


def reported_route(vehicle: VehicleState, props: Mapping[str, Any]) -> tuple[XY, ...]:
    """The rest of an AGV's route as it last published it (``route``), from where it
    stands; ``()`` at rest, failed, or with no well-formed points."""
    ahead = props.get("route")
    if vehicle.status == "failed" or not isinstance(ahead, list | tuple):
        return ()
    points = [
        (float(p[0]), float(p[1]))
        for p in ahead
        if isinstance(p, list | tuple)
        and len(p) == 2
        and all(isinstance(c, int | float) and not isinstance(c, bool) for c in p)
    ]
    return ((vehicle.x, vehicle.y), *points) if points else ()
