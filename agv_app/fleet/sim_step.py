"""What a simulated fleet does to its AGVs at each step: drive them, drain and charge
their batteries, hold the ones the operator stopped, and check safety after; and the
pace at which its steps follow the wall clock.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Mapping

from agv_app.fleet.chargers import Chargers
from agv_app.fleet.holding import HoldOrders
from agv_app.fleet.metrics import FleetMetrics
from agv_app.fleet.parking import ParkingPlan
from agv_app.fleet.stalls import StallWatch
from agv_app.geometry import Area
from agv_app.traffic.monitor import SafetyMonitor, SafetyViolation
from agv_app.vehicle.controller import AgvController
from objectplaces.sim import SimulatedNetwork

__all__ = [
    "Pace",
    "apply_holds",
    "charge",
    "check_safety",
    "drive_agvs",
    "rest_point",
    "takes_tasks",
]


def drive_agvs(
    agvs: Mapping[str, AgvController],
    dt: float,
    now: float,
    *,
    metrics: FleetMetrics,
    stalls: StallWatch,
    net: SimulatedNetwork,
    left: set[str],
) -> None:
    """Step every AGV by ``dt``, counting its time; one whose driver failed leaves the
    network once (noted in ``left``)."""
    for agv_id, agv in agvs.items():
        agv.step(dt)
        metrics.agv_seconds += dt
        if agv.failed:
            if agv.vehicle.fault is not None and agv_id not in left:
                left.add(agv_id)
                net.leave(agv_id)  # it says goodbye: the others keep its circle
            continue
        shown = agv.display_status()
        if shown == "idle":
            metrics.idle_seconds += dt
        elif shown == "waiting":
            metrics.waiting_seconds += dt
        stalls.observe(agv_id, stalled=agv.stalled, now=now)


def check_safety(
    monitor: SafetyMonitor,
    agvs: Mapping[str, AgvController],
    truths: Mapping[str, Callable[[], Area]],
    step: int,
    now: float,
) -> list[SafetyViolation]:
    """Run the safety monitor over the AGVs' hulls (the true one, where a driver says
    it) and their locks."""
    hulls = [(a, truths[a]() if a in truths else agv.vehicle.hull()) for a, agv in agvs.items()]
    # The areas alone: the monitor needs no direction claims, a lookup per lock.
    locks = [(a, area) for a, agv in agvs.items() for _, area in agv.book.lock_areas()]
    return monitor.check(step, now, hulls, locks)


def rest_point(parking: ParkingPlan, chargers: Chargers | None, agv: AgvController) -> str | None:
    """A free rest point for an idle AGV that stands in the way (nearest ahead).

    Rest points are the fleet's to hand out, like a warehouse's parking plan; one
    bound for or on a charger stays.
    """
    if chargers is not None and chargers.stays(agv.node_id):
        return None
    return parking.relocate(agv.node_id, agv.home, agv.point)


def takes_tasks(holds: HoldOrders, chargers: Chargers | None, agv_id: str) -> bool:
    """Whether the AGV may take tasks: the operator has it in service and its battery
    needs no charge."""
    return holds.in_service(agv_id) and (chargers is None or chargers.takes_tasks(agv_id))


def apply_holds(
    agvs: Mapping[str, AgvController], holds: HoldOrders, chargers: Chargers | None
) -> None:
    """Hold or release every AGV as ``holds`` (and an empty battery) says, at once."""
    for agv_id, agv in agvs.items():
        if holds.held(agv_id) or (chargers is not None and chargers.empty(agv_id)):
            agv.hold()
        else:
            agv.release()
        if not holds.in_service(agv_id):
            agv.take_out_of_service()  # hands back a task it has not loaded
        agv.in_service = takes_tasks(holds, chargers, agv_id)


def charge(
    agvs: Mapping[str, AgvController],
    chargers: Chargers,
    holds: HoldOrders,
    dt: float,
    now: float,
) -> None:
    """Drain and charge the batteries; chargers to the AGVs that need one."""
    for agv_id, agv in agvs.items():
        chargers.step(agv_id, agv, dt, now)
        agv.in_service = takes_tasks(holds, chargers, agv_id)
    chargers.grant(agvs, now)


class Pace:
    """Simulated seconds per wall second, and the whole steps of ``dt`` that the wall
    time handed to ``steps`` is worth (the remainder carries over)."""

    def __init__(self, dt: float) -> None:
        self.dt = dt
        self.speed = 1.0
        """The factor last given to ``set_speed``."""
        self._carry = 0.0

    def set_speed(self, factor: float) -> None:
        """Simulated seconds per wall second.

        Raises:
            ValueError: ``factor`` is not positive.
        """
        if not (isinstance(factor, int | float) and factor > 0 and math.isfinite(factor)):
            raise ValueError(f"speed must be a positive number, got {factor!r}")
        self.speed = float(factor)

    def steps(self, seconds: float) -> Iterator[None]:
        """One item per whole step in ``seconds`` and the remainder carried (none for
        ``seconds <= 0``)."""
        if seconds <= 0:
            return
        self._carry += seconds
        dt = self.dt
        while self._carry >= dt - 1e-9:
            self._carry -= dt
            yield
