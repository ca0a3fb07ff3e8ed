"""AGV components built as a fleet asks, with a rule changed: what a rule is for."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any, Final, TypedDict

from agv_app.vehicle import AgvController

__all__ = ["FOUND_AT", "FoundAt", "VehicleFactory", "vehicle_with"]


class FoundAt(TypedDict):
    """Fleet settings (``FleetConfig`` fields) a replayed fleet was found with."""

    advance_m: float
    rest_beat: float | None
    republish: float
    probes: bool
    station_nodes: bool
    max_open_tasks: int | str | None


FOUND_AT: Final = FoundAt(
    advance_m=5.0,
    rest_beat=None,
    republish=60.0,
    probes=False,
    station_nodes=True,
    max_open_tasks=None,
)
"""The settings the fleets that the before-and-after tests replay were found with: 5 m
requests, no rest beats (which widen the interest radius) and every property
republished every sixty heartbeats (a minute at the default heartbeat), no session
probed, each station on a node of its own, no limit on the tasks on the floor. With
other settings their dynamics differ, and most of them no longer lock without the rule
they show."""

VehicleFactory = Callable[..., AgvController]
"""What ``Fleet(vehicle=...)`` takes: builds one AGV component."""


def vehicle_with(controller: type[AgvController] = AgvController, **changes: Any) -> VehicleFactory:
    """An AGV component (``controller``, or a subclass that records what it does) built
    as the fleet asks, with these ``AgvConfig`` fields changed (e.g.
    ``keep_way_out=False``: the fleet without a rule, to show what it does)."""

    def build(*args: Any, config: Any, **kwargs: Any) -> AgvController:
        return controller(*args, config=dataclasses.replace(config, **changes), **kwargs)

    return build
