"""One AGV in full, for the vehicle panel: pose, route ahead, locks, wait, sessions, traffic.

The pose, status and lock state come from the fleet's ``VehicleView``; the sessions and
the traffic from the AGV's own node (an AGV's id is its node id); how long it has been
waiting from the dashboard's watch; the route ahead from the fleet when it can tell
(``RouteSource``, optional: for a fleet without it the route is empty).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from typing import Any, Protocol, runtime_checkable

from dashboard import introspect
from dashboard.capture import COORD_DIGITS, JSON, SessionRecord, vehicle_json
from dashboard.source import XY, NodeHandle, VehicleView

__all__ = ["RouteSource", "route_length", "vehicle_detail"]


@runtime_checkable
class RouteSource(Protocol):
    """A fleet that can say where each AGV is going (optional for a ``FleetSource``)."""

    def vehicle_route(self, vehicle_id: str) -> Sequence[XY]:
        """The rest of the AGV's route, from where it stands to where it stops: ``()``
        when it rests.

        Raises:
            KeyError: no AGV has that id.
        """
        ...


def route_length(points: Sequence[Sequence[float]]) -> float:
    """Length of a polyline in metres (0 for fewer than two points)."""
    return sum(math.dist(a, b) for a, b in itertools.pairwise(points))


def _route_of(source: object, vehicle_id: str) -> list[list[float]]:
    if not isinstance(source, RouteSource):
        return []
    try:
        points = source.vehicle_route(vehicle_id)
    except KeyError:
        return []
    return [[round(float(x), COORD_DIGITS), round(float(y), COORD_DIGITS)] for x, y in points]


def _traffic(node: NodeHandle) -> JSON:
    stats = node.stats()
    return {
        "frames_sent": int(stats.messages_sent),
        "bytes_sent": int(stats.bytes_sent),
        "frames_received": int(stats.messages_received),
        "bytes_received": int(stats.bytes_received),
        "sent": {k: [int(n), int(b)] for k, (n, b) in sorted(stats.sent.items())},
        "received": {k: [int(n), int(b)] for k, (n, b) in sorted(stats.received.items())},
    }


def _participations(
    node: NodeHandle, sessions: Mapping[str, SessionRecord], now: float
) -> list[JSON]:
    out: list[JSON] = []
    for part in introspect.participations_of(node):
        rec = sessions.get(part["session_id"])
        out.append(
            {
                **part,
                "initiator_role": rec.role if rec else None,
                "members": len(rec.members) if rec else None,
                "age_s": round(max(0.0, now - rec.started_at), COORD_DIGITS) if rec else None,
            }
        )
    return sorted(out, key=lambda p: p["session_id"])


def vehicle_detail(
    source: object,
    vehicle: VehicleView,
    *,
    node: NodeHandle | None,
    sessions: Mapping[str, SessionRecord],
    waiting_since: float | None,
    now: float,
) -> JSON:
    """The vehicle panel's record of one AGV.

    Args:
        source: the fleet (asked for the route when it is a ``RouteSource``).
        vehicle: the AGV as the fleet shows it.
        node: the AGV's node, or None when it has none now (it failed).
        sessions: every live session by id (for the sessions it takes part in).
        waiting_since: when the AGV began to wait, if it waits.
        now: simulated seconds.

    Returns:
        ``vehicle_json`` plus ``route``, ``route_length``, ``destination``, ``wait``,
        ``initiated``, ``participating`` and ``traffic``.
    """
    route = _route_of(source, vehicle.id)
    waiting = str(vehicle.status) == "waiting"
    since = waiting_since if waiting else None
    initiated: list[Any] = []
    participating: list[JSON] = []
    traffic: JSON | None = None
    if node is not None:
        for rec in introspect.sessions_of(vehicle.id, node):
            shown = sessions.get(rec.session_id, rec)
            initiated.append(
                {**shown.as_json(), "age_s": round(max(0.0, now - rec.started_at), COORD_DIGITS)}
            )
        participating = _participations(node, sessions, now)
        traffic = _traffic(node)
    return {
        "id": vehicle.id,
        **vehicle_json(vehicle),
        "route": route,
        "route_length": round(route_length(route), COORD_DIGITS),
        "destination": route[-1] if route else None,
        "wait": {
            "waiting": waiting,
            "since": since,
            "seconds": None if since is None else round(max(0.0, now - since), COORD_DIGITS),
        },
        "initiated": initiated,
        "participating": participating,
        "traffic": traffic,
    }
