"""AGV components built as a fleet asks, with a rule changed: what a rule is for."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

from agv_app.vehicle import AgvController

__all__ = ["VehicleFactory", "vehicle_with"]

VehicleFactory = Callable[..., AgvController]
"""What ``Fleet(vehicle=...)`` takes: builds one AGV component."""


def vehicle_with(controller: type[AgvController] = AgvController, **changes: Any) -> VehicleFactory:
    """An AGV component (``controller``, or a subclass that records what it does) built
    as the fleet asks, with these ``AgvConfig`` fields changed (e.g.
    ``keep_way_out=False``: the fleet without a rule, to show what it does)."""

    def build(*args: Any, config: Any, **kwargs: Any) -> AgvController:
        return controller(*args, config=dataclasses.replace(config, **changes), **kwargs)

    return build
