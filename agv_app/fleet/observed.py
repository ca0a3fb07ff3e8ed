"""What an observer node hears of AGVs it does not run: their state, shapes and safety.

An AGV process publishes its position and hull length, and shows the observer what it
needs to draw it (its pose as it moves, ``heading``, ``state``, ``size``, ``task``) and
its ``locked`` and ``requested`` projections in the compact form of
:func:`~agv_app.geometry.polygon_to_coords` (:mod:`agv_app.fleet.display_feed`). The
shapes are decoded once per change (:class:`ObservedAgv`); :func:`vehicle_state`
turns the properties into the dashboard's :class:`~agv_app.fleet.view.VehicleState`.

The safety check over observed shapes is best effort (:class:`LastingOverlaps`): views
lag the vehicles by the publication interval, and the observer hears each AGV at a
different moment, so only overlaps that last count.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from agv_app.fleet.view import VehicleState, area_rings
from agv_app.geometry import Area, Pose, coords_to_polygon, hull
from agv_app.layout.demo import DEMO_VEHICLE_LENGTH_M, DEMO_VEHICLE_WIDTH_M
from agv_app.traffic.monitor import SafetyMonitor, SafetyViolation

__all__ = ["LastingOverlaps", "ObservedAgv", "vehicle_state"]

_SHRINK_M = 0.01  # more than the centimetre rounding of the wire form


def _number(value: Any, default: float = 0.0) -> float:
    if isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value):
        return float(value)
    return default


def _percent(value: Any) -> float | None:
    """A state of charge as reported (None: none reported, or not a percentage)."""
    number = _number(value, math.nan)
    return number if 0.0 <= number <= 100.0 else None


def _decode(coords: Any) -> Area:
    """An area from its wire form; empty when absent or malformed (a peer sent it)."""
    if not coords:
        return Area.empty()
    try:
        return coords_to_polygon(coords)
    except (TypeError, ValueError):
        return Area.empty()


class ObservedAgv:
    """What the observer last heard of one AGV's projections, decoded once per change."""

    __slots__ = ("locked", "locked_area", "raw_locked", "raw_requested", "requested")

    def __init__(self) -> None:
        self.raw_locked: Any = None
        self.raw_requested: Any = None
        self.locked: tuple[tuple[tuple[float, float], ...], ...] = ()
        self.requested: tuple[tuple[tuple[float, float], ...], ...] = ()
        self.locked_area = Area.empty()

    def update(self, props: Mapping[str, Any]) -> None:
        """Take the AGV's current properties (re-decodes only what changed)."""
        locked, requested = props.get("locked"), props.get("requested")
        if locked is not self.raw_locked:
            self.raw_locked = locked
            self.locked_area = _decode(locked)
            self.locked = area_rings(self.locked_area)
        if requested is not self.raw_requested:
            self.raw_requested = requested
            self.requested = area_rings(_decode(requested))


def vehicle_state(agv_id: str, props: Mapping[str, Any], seen: ObservedAgv) -> VehicleState:
    """The dashboard's view of one AGV from its published properties.

    Args:
        agv_id: the AGV's node id.
        props: its properties and display as the observer holds them (``position`` is a
            tuple).
        seen: its decoded projections (updated here).
    """
    x, y = (_number(c) for c in props["position"][:2])
    heading = _number(props.get("heading"))
    size = props.get("size")
    length, width = DEMO_VEHICLE_LENGTH_M, DEMO_VEHICLE_WIDTH_M
    if isinstance(size, list | tuple) and len(size) == 2:
        length, width = _number(size[0], length), _number(size[1], width)
    seen.update(props)
    ring = area_rings(hull(Pose(x, y, heading), length=length, width=width))
    state = props.get("state", props.get("status"))
    task = props.get("task")
    return VehicleState(
        agv_id,
        x,
        y,
        heading,
        length,
        width,
        state if isinstance(state, str) else "unknown",
        task if isinstance(task, str) else None,
        ring[0],
        _number(props.get("hull_length")),
        seen.locked,
        seen.requested,
        _number(props.get("speed")),
        props.get("held") is True,
        props.get("in_service") is not False,
        _percent(props.get("battery")),
    )


class LastingOverlaps:
    """Counts overlaps of observed hulls and locks into ``monitor`` once they last.

    Args:
        monitor: where the counts and the first violations go.
        min_s: how long an overlap must last to count.
    """

    def __init__(self, monitor: SafetyMonitor, *, min_s: float) -> None:
        self.monitor = monitor
        self.min_s = min_s
        self._checks = 0
        self._suspects: dict[tuple[str, str, str], float] = {}
        self._counted: set[tuple[str, str, str]] = set()

    def check(
        self,
        now: float,
        vehicles: Sequence[VehicleState],
        observed: Mapping[str, ObservedAgv],
    ) -> None:
        """Check the observed hulls and locks at ``now``; count overlaps that lasted."""
        self._checks += 1
        hulls = [
            (
                v.id,
                hull(Pose(v.x, v.y, v.heading_rad), length=v.length_m, width=v.width_m).buffer(
                    -_SHRINK_M
                ),
            )
            for v in vehicles
        ]
        locks = [
            (v.id, observed[v.id].locked_area.buffer(-_SHRINK_M))
            for v in vehicles
            if v.id in observed
        ]
        # A fresh monitor reports every overlap present now, not only new ones.
        found = SafetyMonitor(tolerance_m2=self.monitor.tolerance_m2).check(
            self._checks, now, hulls, locks
        )
        current: dict[tuple[str, str, str], SafetyViolation] = {(v.kind, *v.agvs): v for v in found}
        self._suspects = {k: self._suspects.get(k, now) for k in current}
        monitor = self.monitor
        for key, since in self._suspects.items():
            if now - since >= self.min_s and key not in self._counted:
                self._counted.add(key)
                if key[0] == "collision":
                    monitor.collisions += 1
                else:
                    monitor.lock_overlaps += 1
                if len(monitor.violations) < monitor.keep:
                    monitor.violations.append(current[key])
        self._counted &= set(current)
