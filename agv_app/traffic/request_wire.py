"""Requests on the wire: a requested projection's wire form, the request message, and
the probes of received requests a process shares (:mod:`agv_app.traffic.collision`)."""

from __future__ import annotations

from typing import Any

import shapely

from agv_app.geometry import Area, coords_to_polygon, polygon_to_coords
from agv_app.geometry.probe import Probe
from agv_app.traffic.fifo import AGE_FIELD
from agv_app.traffic.lockbook import RequestEntry

__all__ = ["WIRE_GROWTH_M", "received_request", "request_coords", "request_message"]

WIRE_GROWTH_M = 0.1
"""How much a requested projection grows on the wire (:func:`request_coords`)."""


def request_coords(area: Area, *, grow_m: float = WIRE_GROWTH_M, tolerance_m: float = 0.08) -> Any:
    """Wire form of a requested projection: grown by ``grow_m``, then simplified.

    Simplifying by less than it was grown keeps the original inside, so a voter never
    under-estimates the request; far fewer vertices travel (turn arcs are smooth).
    """
    # Vertices a hair apart (where a route turns back on itself) make the mitre
    # buffer divide by zero; dropping them moves no edge by more than a micrometre.
    clean = shapely.remove_repeated_points(area.geom, 1e-6)
    grown = clean.buffer(grow_m, join_style="mitre").simplify(tolerance_m)
    return polygon_to_coords(Area(grown), margin_m=0.0)


_REQUESTS_KEPT = 256
_requests_received: dict[Any, Probe] = {}


def received_request(coords: Any) -> Probe:
    """A probe of ``coords_to_polygon(coords)``, shared by the voters of one process: a
    request goes to every member of the group, and on a simulated floor they all
    decode it and test it against their locks from the same requester's circle."""
    key = tuple(tuple(tuple(ring) for ring in polygon) for polygon in coords)
    probe = _requests_received.get(key)
    if probe is None:
        probe = Probe(coords_to_polygon(coords))
        if len(_requests_received) >= _REQUESTS_KEPT:
            del _requests_received[next(iter(_requests_received))]
        _requests_received[key] = probe
    return probe


def request_message(entry: RequestEntry) -> dict[str, Any]:
    """The ``req`` message that asks a group to allow ``entry``."""
    message: dict[str, Any] = {
        "t": "req",
        "k": entry.key,
        "p": [entry.priority[0], entry.priority[1]],
        "a": request_coords(entry.area),
    }
    if entry.age is not None and entry.age != entry.priority[0]:
        message[AGE_FIELD] = entry.age
    if entry.claims:
        message["c"] = [[seg, way] for seg, way in sorted(entry.claims)]
    return message
