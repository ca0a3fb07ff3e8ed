"""What a simulated fleet shows: its vehicles as the dashboard draws them, and the
run's figures (:meth:`~agv_app.fleet.sim.Fleet.summary`).
"""

from __future__ import annotations

from collections.abc import Mapping

from agv_app.fleet.chargers import Chargers
from agv_app.fleet.metrics import FleetMetrics
from agv_app.fleet.stalls import StallWatch
from agv_app.fleet.view import VehicleState, area_rings
from agv_app.geometry import XY
from agv_app.samples import percentile
from agv_app.tasks.book import TaskBook
from agv_app.tasks.desk import TaskDesk
from agv_app.tasks.free_flow import FreeFlowBound
from agv_app.traffic.monitor import SafetyMonitor
from agv_app.vehicle.controller import AgvController
from agv_app.vehicle.kinematics import VehicleSpec
from objectplaces.sim import SimulatedNetwork

__all__ = ["fleet_summary", "route_ahead", "shown_status", "task_lead_ratios", "vehicle_states"]


def vehicle_states(
    agvs: Mapping[str, AgvController],
    spec: VehicleSpec,
    chargers: Chargers | None,
    now: float,
) -> list[VehicleState]:
    """Every AGV as the dashboard draws it, by id."""
    out = []
    for agv_id, agv in sorted(agvs.items()):
        pose = agv.vehicle.pose()
        locks, request = agv.areas()
        hull = area_rings(agv.vehicle.hull())
        out.append(
            VehicleState(
                agv_id,
                pose.x,
                pose.y,
                pose.heading_rad,
                spec.length_m,
                spec.width_m,
                shown_status(agv_id, agv, chargers),
                agv.task.id if agv.task else (agv.pending_task.id if agv.pending_task else None),
                hull[0] if hull else (),
                agv.current_hull_length(),
                tuple(r for a in locks for r in area_rings(a)),
                area_rings(request),
                agv.vehicle.speed,
                agv.held,
                agv.in_service,
                None if chargers is None else chargers.state_of_charge(agv_id, now),
            )
        )
    return out


def shown_status(agv_id: str, agv: AgvController, chargers: Chargers | None) -> str:
    """The dashboard's status: ``charging``, ``to-charger`` or ``empty`` when the
    battery says so, else the AGV's own."""
    by_battery = None if chargers is None else chargers.status(agv_id)
    return by_battery or agv.display_status()


def route_ahead(agv: AgvController) -> tuple[XY, ...]:
    """The rest of an AGV's route, from where it stands to where it stops; ``()`` at
    rest or failed."""
    vehicle = agv.vehicle
    if agv.failed or vehicle.remaining() <= 1e-9:
        return ()
    return tuple(vehicle.route.slice(vehicle.s, vehicle.route.length).coords)


def task_lead_ratios(book: TaskBook, free_flow: FreeFlowBound) -> list[float]:
    """Each delivered task's lead time (from its creation, time at the task desk
    included, to its delivery) over its free-flow lead time (the same in the free-flow
    replay), for the tasks ``book`` still holds in detail, oldest first."""
    ratios = []
    for record in book.records():
        ideal = free_flow.lead_seconds(record.id)
        if record.state == "done" and ideal:
            ratios.append((record.times["done"] - record.times["created"]) / ideal)
    return ratios


def fleet_summary(
    net: SimulatedNetwork,
    agvs: Mapping[str, AgvController],
    metrics: FleetMetrics,
    desk: TaskDesk,
    *,
    stalls: StallWatch,
    free_flow: FreeFlowBound,
    monitor: SafetyMonitor,
    chargers: Chargers | None,
    wait_bound_s: float,
    wall_seconds: float,
) -> dict[str, float]:
    """The run's figures (see ``FleetMetrics.summary``), the batteries' when there are
    any, ``lead_ratio_p95`` (:func:`task_lead_ratios`) after the task times and
    ``wait_bound`` (``wait_bound_s``) after the longest wait."""
    stats = net.stats()
    agv_sent: dict[str, tuple[int, int]] = {}
    for agv_id in agvs:
        traffic = stats.per_node.get(agv_id)
        if traffic is None:
            continue
        for kind, (n, b) in traffic.sent.items():
            old = agv_sent.get(kind, (0, 0))
            agv_sent[kind] = (old[0] + n, old[1] + b)
    figures = metrics.summary(
        tasks=desk.book,
        tasks_returned=desk.returned,
        tasks_refused=desk.refused,
        stalls=stalls,
        free_flow_tasks_per_hour=free_flow.per_hour(net.now),
        agvs=len(agvs),
        sim_seconds=net.now,
        wall_seconds=wall_seconds,
        collisions=monitor.collisions,
        lock_overlaps=monitor.lock_overlaps,
        messages=stats.messages,
        bytes_=stats.bytes,
        agv_sent=agv_sent,
    ) | ({} if chargers is None else chargers.stats.summary())
    # Beside the task times, their share of free flow; beside the longest wait, what
    # it may be at most.
    lead = {"lead_ratio_p95": round(percentile(task_lead_ratios(desk.book, free_flow), 95), 3)}
    figures = _insert_after(figures, "task_time_p95", lead)
    return _insert_after(figures, "max_wait", {"wait_bound": round(wait_bound_s, 2)})


def _insert_after(figures: dict[str, float], key: str, more: dict[str, float]) -> dict[str, float]:
    keys = list(figures)
    at = keys.index(key) + 1
    return {k: figures[k] for k in keys[:at]} | more | {k: figures[k] for k in keys[at:]}
