"""What the node actions do to a vehicle: loads picked and dropped, charging started and
stopped, and which of them a node of the layout allows.

A vehicle carries one load at most, on its one load handling device ``carrier``. A pick
needs a station at its node that hands out loads (kind ``pick`` or ``pickdrop``), a drop
one that takes them (``drop`` or ``pickdrop``); each runs for the station's load
handling time (``AgvConfig.dwell``, what a desk task dwells there too). Charging needs
a charging station at its node (:mod:`agv_app.vda5050.charging`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Final

from agv_app.layout.graph import Layout
from agv_app.vda5050.actions import OrderAction
from agv_app.vda5050.charging import Battery, charger_at
from agv_app.vda5050.reports import INVALID_ORDER_ACTION, LOAD_HANDLING_FAILED, VdaError

__all__ = ["LOAD_POSITION", "Load", "LoadHandling", "node_action_problem", "station_for"]

LOAD_POSITION: Final = "carrier"
"""The vehicle's one load handling device (the factsheet's ``loadPositions``)."""

_PICK_KINDS: Final = frozenset({"pick", "pickdrop"})
_DROP_KINDS: Final = frozenset({"drop", "pickdrop"})
_LOAD_KEYS: Final = frozenset({"loadId", "loadType", "stationName", "stationType", "lhd"})


@dataclass(frozen=True, slots=True)
class Load:
    """A load on board."""

    load_id: str = ""
    load_type: str = ""

    def to_json(self) -> dict[str, Any]:
        """The state's ``load`` object (no ``loadPosition``: the vehicle has one)."""
        out: dict[str, Any] = {}
        if self.load_id:
            out["loadId"] = self.load_id
        if self.load_type:
            out["loadType"] = self.load_type
        return out


def station_for(layout: Layout, point: str, kinds: frozenset[str]) -> str | None:
    """The station of one of ``kinds`` at ``point`` (None: none)."""
    return next(
        (
            s.id
            for s in sorted(layout.stations.values(), key=lambda s: s.id)
            if s.point == point and s.kind in kinds
        ),
        None,
    )


def node_action_problem(layout: Layout, action: OrderAction) -> str | None:
    """Why the vehicle cannot carry out node action ``action`` at its node (None: it can).

    Only pick, drop, startCharging and stopCharging are node actions here; the caller
    has checked the type and blocking type against the catalogue.
    """
    kind = action.action_type
    if kind in ("pick", "drop"):
        for key, value in action.parameters:
            if key not in _LOAD_KEYS:
                return f"{kind} takes no parameter {key!r}"
            if not isinstance(value, str):
                return f"{kind}'s parameter {key!r} must be a string"
        if action.parameter("lhd") not in (None, LOAD_POSITION):
            return f"the vehicle's load handling device is {LOAD_POSITION!r}"
        kinds = _PICK_KINDS if kind == "pick" else _DROP_KINDS
        station = station_for(layout, action.node_id, kinds)
        if station is None:
            what = "hands out loads" if kind == "pick" else "takes loads"
            return f"no station at node {action.node_id!r} {what}"
        name = action.parameter("stationName")
        if name is not None and name != station:
            return f"the station at node {action.node_id!r} is {station!r}, not {name!r}"
    elif action.parameters:
        return f"{kind} takes no parameters"
    if kind == "startCharging" and charger_at(layout, action.node_id) is None:
        return f"no charging station at node {action.node_id!r}"
    return None


class LoadHandling:
    """The effects of node actions on one vehicle (an :class:`~agv_app.vda5050.actions.
    Effects`).

    Args:
        layout: the floor plan, for its stations.
        battery: the vehicle's battery.
        handling_s: the load handling time of a station, seconds.
        standing_at: where the vehicle stands now (None: between points).
    """

    def __init__(
        self,
        layout: Layout,
        battery: Battery,
        *,
        handling_s: float,
        standing_at: Callable[[], str | None],
    ) -> None:
        self.layout = layout
        self.battery = battery
        self.handling_s = handling_s
        self.standing_at = standing_at
        self.loads: list[Load] = []

    def begin(self, action: OrderAction, now: float) -> float | VdaError:
        """Start ``action``: pick and drop run for the load handling time, charging
        starts or stops at once."""
        ref = (("actionId", action.action_id), ("nodeId", action.node_id))
        kind = action.action_type
        if kind == "pick" and self.loads:
            return VdaError(LOAD_HANDLING_FAILED, "pick: the vehicle carries a load already", ref)
        if kind == "drop" and not self.loads:
            return VdaError(LOAD_HANDLING_FAILED, "drop: the vehicle carries no load", ref)
        if kind in ("pick", "drop"):
            return self.handling_s
        if kind == "startCharging":
            point = self.standing_at()
            if point is None or charger_at(self.layout, point) is None:
                return VdaError(
                    INVALID_ORDER_ACTION,
                    f"startCharging: no charging station where the vehicle stands ({point!r})",
                    ref,
                )
            self.battery.start_charging(now)
        elif kind == "stopCharging":
            self.battery.stop_charging(now)
        return 0.0

    def complete(self, action: OrderAction, now: float) -> str | VdaError:
        """End ``action``: the load is on board, or left at the station."""
        kind = action.action_type
        if kind == "pick":
            load_id, load_type = action.parameter("loadId"), action.parameter("loadType")
            load = Load(str(load_id or ""), str(load_type or ""))
            self.loads.append(load)
            return f"picked {load.load_id or 'a load'}"
        if kind == "drop":
            load = self.loads.pop()
            return f"dropped {load.load_id or 'the load'}"
        if kind == "startCharging":
            return "charging" if self.battery.charging else "full: not charging"
        return "not charging"
