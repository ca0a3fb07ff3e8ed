"""The actions the vehicle can carry out, as its factsheet lists them.

:data:`CATALOGUE` lists every action the vehicle carries out, with its scopes, blocking
types, parameters and whether it can be paused or cancelled (the factsheet's
``mobileRobotActions`` are made from it). How the actions of an order run is
:mod:`agv_app.vda5050.actions`' job; this module only describes them.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Final

__all__ = ["BLOCKING_TYPES", "CATALOGUE", "ActionSpec", "ParameterSpec"]

BLOCKING_TYPES: Final = ("NONE", "SINGLE", "SOFT", "HARD")
"""Every blocking type of VDA 5050 3.0 (section 6.2.2, Table 3)."""


@dataclass(frozen=True, slots=True)
class ParameterSpec:
    """One parameter of an action as the factsheet lists it."""

    key: str
    value_type: str
    description: str
    optional: bool = True

    def to_json(self) -> dict[str, Any]:
        """The factsheet's ``actionParameter`` object."""
        return {
            "key": self.key,
            "valueDataType": self.value_type,
            "description": self.description,
            "isOptional": self.optional,
        }


@dataclass(frozen=True, slots=True)
class ActionSpec:
    """An action the vehicle carries out: where it may be used and how.

    Attributes:
        action_type: the ``actionType``.
        description: what it does here.
        scopes: ``INSTANT`` and/or ``NODE``.
        blocking_types: the blocking types it is accepted with on a node.
        parameters: the ``actionParameters`` it takes (others are refused).
        pause_allowed: ``startPause`` pauses it while it runs.
        cancel_allowed: ``cancelOrder`` stops it while it runs.
        result: what its ``actionResult`` says.
    """

    action_type: str
    description: str
    scopes: tuple[str, ...]
    blocking_types: tuple[str, ...] = BLOCKING_TYPES
    parameters: tuple[ParameterSpec, ...] = ()
    pause_allowed: bool = False
    cancel_allowed: bool = True
    result: str = ""

    def to_json(self) -> dict[str, Any]:
        """The factsheet's ``mobileRobotAction`` object."""
        out: dict[str, Any] = {
            "actionType": self.action_type,
            "actionDescription": self.description,
            "actionScopes": list(self.scopes),
            "blockingTypes": list(self.blocking_types),
            "pauseAllowed": self.pause_allowed,
            "cancelAllowed": self.cancel_allowed,
        }
        if self.parameters:
            out["actionParameters"] = [p.to_json() for p in self.parameters]
        if self.result:
            out["actionResult"] = self.result
        return out


_LOAD_PARAMETERS = (
    ParameterSpec("loadId", "STRING", "the load's id, reported in state.loads"),
    ParameterSpec("loadType", "STRING", "the load's type, reported in state.loads"),
    ParameterSpec("stationName", "STRING", "the layout's station at the node (checked)"),
    ParameterSpec("stationType", "STRING", "informational"),
    ParameterSpec("lhd", "STRING", "the load handling device: 'carrier', the only one"),
)
_POSE_PARAMETERS = (
    ParameterSpec("x", "NUMBER", "metres, the layout's frame", optional=False),
    ParameterSpec("y", "NUMBER", "metres, the layout's frame", optional=False),
    ParameterSpec("theta", "NUMBER", "radians", optional=False),
    ParameterSpec("mapId", "STRING", "the layout's name", optional=False),
    ParameterSpec("lastNodeId", "STRING", "the layout point the vehicle stands on", optional=False),
)

CATALOGUE: Final[Mapping[str, ActionSpec]] = {
    spec.action_type: spec
    for spec in (
        ActionSpec(
            "pick",
            "takes a load at a pick station; runs for the station's load handling time",
            ("NODE",),
            blocking_types=("SOFT", "HARD"),
            parameters=_LOAD_PARAMETERS,
            pause_allowed=True,
            cancel_allowed=False,
            result="the load picked",
        ),
        ActionSpec(
            "drop",
            "leaves the load at a drop station; runs for the station's load handling time",
            ("NODE",),
            blocking_types=("SOFT", "HARD"),
            parameters=_LOAD_PARAMETERS,
            pause_allowed=True,
            cancel_allowed=False,
            result="the load dropped",
        ),
        ActionSpec(
            "startCharging",
            "starts charging on a charging station of the layout; driving off stops it",
            ("INSTANT", "NODE"),
        ),
        ActionSpec("stopCharging", "stops charging", ("INSTANT", "NODE")),
        ActionSpec("startPause", "brakes to a standstill and pauses what may pause", ("INSTANT",)),
        ActionSpec("stopPause", "drives on and resumes what was paused", ("INSTANT",)),
        ActionSpec(
            "cancelOrder",
            "stops at the next node it can stop at and drops the rest of the order",
            ("INSTANT",),
            parameters=(ParameterSpec("orderId", "STRING", "the order to cancel"),),
        ),
        ActionSpec("stateRequest", "publishes a state", ("INSTANT",)),
        ActionSpec("factsheetRequest", "publishes the factsheet", ("INSTANT",)),
        ActionSpec(
            "clearInstantActions",
            "removes the finished and failed instant actions from the state",
            ("INSTANT",),
        ),
        ActionSpec(
            "initializePosition",
            "confirms the vehicle's pose and last node; it must be where the vehicle stands",
            ("INSTANT",),
            parameters=_POSE_PARAMETERS,
        ),
        ActionSpec(
            "initPosition",
            "the VDA 5050 2.x name of initializePosition",
            ("INSTANT",),
            parameters=_POSE_PARAMETERS,
        ),
    )
}
"""Every action the vehicle carries out, by ``actionType``."""
