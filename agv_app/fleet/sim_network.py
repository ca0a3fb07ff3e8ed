"""The simulated fleet's network: its nodes' liveness, the delays the dissemination
margin allows for, and who hears whom (the AGVs' interest radius and footprints,
:mod:`agv_app.traffic.reach`).
"""

from __future__ import annotations

from collections.abc import Iterable

from agv_app.fleet.liveness import REPUBLISH_BEATS, fleet_liveness
from agv_app.fleet.sim_config import FleetConfig
from agv_app.layout.graph import Layout
from agv_app.traffic.reach import dissemination_margin, interest_radius
from agv_app.traffic.wait_bound import WaitBound, wait_bound
from agv_app.vehicle.controller import AgvConfig
from agv_app.vehicle.driven import planning_spec
from agv_app.vehicle.driver import VehicleDriver
from agv_app.vehicle.kinematics import VehicleSpec
from objectplaces.core.config import NodeConfig
from objectplaces.core.spatial import MAX_SCOPE_CELLS, footprint_cells
from objectplaces.sim import SimulatedNetwork

__all__ = [
    "fleet_network",
    "fleet_plan_spec",
    "fleet_wait_bound",
    "network_timing",
    "node_liveness",
    "scoped_footprint_margin",
    "scoped_interest_radius",
]


def node_liveness(cfg: FleetConfig) -> NodeConfig:
    """The nodes' liveness settings: heartbeat, republication, rest, timeout."""
    heartbeat = cfg.t_update if cfg.heartbeat is None else cfg.heartbeat
    republish = heartbeat * REPUBLISH_BEATS if cfg.republish is None else cfg.republish
    return fleet_liveness(
        heartbeat, republish=republish if cfg.beats else None, rest_beat=cfg.rest_beat
    )


def fleet_network(cfg: FleetConfig, liveness: NodeConfig) -> SimulatedNetwork:
    """The network the fleet's nodes run on: ``cfg``'s seed, delays and faults, with
    ``liveness``."""
    return SimulatedNetwork(
        cfg.seed,
        delay=cfg.delay,
        jitter=cfg.jitter,
        jitter_per_frame=cfg.jitter_per_frame,
        loss=cfg.loss,
        reorder=cfg.reorder,
        duplicate=cfg.duplicate,
        property_interval=liveness.property_interval,
        beat_interval=liveness.beat_interval,
        rest_beat_interval=liveness.rest_beat_interval,
        failure_timeout=liveness.failure_timeout,
        probe_interval=liveness.probe_interval if cfg.probes else None,
    )


def network_timing(cfg: FleetConfig, liveness: NodeConfig) -> dict[str, float]:
    """The network delay and failure detection the dissemination margin allows for."""
    # A held-back frame waits up to four more delays (SimulatedNetwork's reorder).
    worst_delay = (cfg.delay + cfg.jitter) * (5 if cfg.reorder else 1)
    detection = liveness.failure_detection_bound
    assert detection is not None  # the fleet's nodes always detect failures
    return {"delay_s": worst_delay, "failure_detection_s": detection}


def fleet_wait_bound(
    cfg: FleetConfig,
    layout: Layout,
    spec: VehicleSpec,
    agv_config: AgvConfig,
    liveness: NodeConfig,
    agvs: int | None = None,
) -> WaitBound:
    """The longest any AGV of the fleet waits, from the layout and the fleet
    (docs/traffic.md, "Bounded waits"), ``agvs`` of them moving (None: all)."""
    return wait_bound(
        layout,
        spec,
        agv_config,
        agvs=cfg.agvs if agvs is None else agvs,
        delay_s=network_timing(cfg, liveness)["delay_s"],
        step_s=cfg.dt,
    )


def fleet_plan_spec(spec: VehicleSpec, drivers: Iterable[VehicleDriver | None]) -> VehicleSpec:
    """The widest of the AGVs' planning specs (their drivers' declarations, ``spec``
    without a driver): what the interest radius allows for."""
    widest = spec
    for driver in drivers:
        if driver is not None:
            widest = _widest(widest, planning_spec(spec, driver.limits))
    return widest


def scoped_interest_radius(
    cfg: FleetConfig,
    layout: Layout,
    plan_spec: VehicleSpec,
    agv_config: AgvConfig,
    timing: dict[str, float],
    cell_size: float,
) -> float | None:
    """The AGV nodes' interest radius (None: they hear every node): ``cfg``'s, or from the
    layout and the widest planning spec, unless the run is broadcast or not scoped."""
    if cfg.broadcast or not cfg.scoped:
        return None
    if cfg.interest_radius is not None:
        return cfg.interest_radius
    radius = interest_radius(layout, plan_spec, agv_config, footprints=cfg.footprints, **timing)
    # A floor whose runs are so long that the square of cells about the radius is more
    # than a node may subscribe to: every node hears every node, which is always safe.
    if footprint_cells(radius, 0.0, cell_size) > MAX_SCOPE_CELLS:
        return None
    return radius


def scoped_footprint_margin(
    cfg: FleetConfig,
    radius: float | None,
    plan_spec: VehicleSpec,
    agv_config: AgvConfig,
    timing: dict[str, float],
) -> float | None:
    """The AGV nodes' footprint margin (None: they publish in their own cell)."""
    if radius is None or not cfg.footprints:
        return None
    # Half the margin on each side: the interest radius carries the other half.
    return dissemination_margin(plan_spec, agv_config, **timing) / 2


def _widest(a: VehicleSpec, b: VehicleSpec) -> VehicleSpec:
    """A spec at least as large, fast and slow to brake as both."""
    if a == b:
        return a
    return VehicleSpec(
        max(a.length_m, b.length_m),
        max(a.width_m, b.width_m),
        max(a.max_speed_m_s, b.max_speed_m_s),
        min(a.max_accel_m_s2, b.max_accel_m_s2),
        a.battery,
    )
