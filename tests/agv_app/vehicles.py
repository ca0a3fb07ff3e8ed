"""AGV components built as a fleet asks, with a rule changed: what a rule is for."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

from agv_app.vehicle import AgvController

__all__ = ["FOUND_AT_ADVANCE_M", "VehicleFactory", "vehicle_with"]

FOUND_AT_ADVANCE_M = 5.0
"""The request length (``FleetConfig.advance_m``) the fleets that the before-and-after
tests replay were found with: with shorter requests their dynamics differ, and most of
them no longer lock without the rule they show."""

VehicleFactory = Callable[..., AgvController]
"""What ``Fleet(vehicle=...)`` takes: builds one AGV component."""


def vehicle_with(controller: type[AgvController] = AgvController, **changes: Any) -> VehicleFactory:
    """An AGV component (``controller``, or a subclass that records what it does) built
    as the fleet asks, with these ``AgvConfig`` fields changed (e.g.
    ``keep_way_out=False``: the fleet without a rule, to show what it does)."""

    def build(*args: Any, config: Any, **kwargs: Any) -> AgvController:
        return controller(*args, config=dataclasses.replace(config, **changes), **kwargs)

    return build
