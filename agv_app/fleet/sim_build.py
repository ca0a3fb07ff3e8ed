"""The parts a simulated fleet is built from: where its AGVs stand at first, its task
rate, its task desk and the nodes that run the desk's stations.
"""

from __future__ import annotations

import math
import random
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from agv_app.fleet.parking import home_heading
from agv_app.fleet.sim_config import FleetConfig
from agv_app.geometry import Pose
from agv_app.layout.graph import Layout
from agv_app.protocol import MessageTally
from agv_app.tasks.admission import limit_for
from agv_app.tasks.auction import TaskSpec
from agv_app.tasks.desk import BASE_ID, TaskDesk, pick_stations
from agv_app.tasks.journal import TaskJournal
from agv_app.tasks.load import fleet_floor_rules, floor_vehicles, task_interval_for_load
from agv_app.traffic.wait_bound import WaitBound
from agv_app.vehicle.comeback import hand_back
from agv_app.vehicle.controller import AgvConfig, AgvController
from agv_app.vehicle.kinematics import VehicleSpec
from objectplaces.sim import SimulatedNetwork

__all__ = [
    "FleetTasks",
    "Placement",
    "active_fleet",
    "fleet_agv_config",
    "fleet_desk",
    "fleet_task_stream",
    "fleet_tasks",
    "open_bases",
    "place_agvs",
    "pose_at",
    "take_over",
]


@dataclass(frozen=True, slots=True)
class Placement:
    """Where each AGV of a fleet stands at first, in the order of ``ids``.

    Attributes:
        ids: the AGVs' ids (``agv-01`` ...).
        starts: the layout point each stands on.
        poses: its pose there.
    """

    ids: list[str]
    starts: list[str]
    poses: list[Pose]


def pose_at(layout: Layout, point: str, heading: float | None) -> Pose:
    """A vehicle's pose on ``point``, heading ``heading`` (None: along the way into the
    spot, ``home_heading``)."""
    p = layout.point(point)
    return Pose(p.x, p.y, home_heading(layout, point) if heading is None else heading)


def place_agvs(
    layout: Layout,
    homes: Sequence[str],
    agvs: int,
    *,
    starts: Sequence[str] | None,
    headings: Sequence[float] | None,
) -> Placement:
    """An id for the AGV of each home (as wide as ``agvs`` needs), and where it stands at
    first: on ``starts`` (default: its home), heading ``headings`` (default: along the
    way into its spot)."""
    width = max(2, len(str(agvs)))
    ids = [f"agv-{i + 1:0{width}d}" for i in range(len(homes))]
    firsts = [home if starts is None else starts[i] for i, home in enumerate(homes)]
    poses = [
        pose_at(layout, point, None if headings is None else headings[i])
        for i, point in enumerate(firsts)
    ]
    return Placement(ids, firsts, poses)


def active_fleet(cfg: FleetConfig, bound: WaitBound, spec: VehicleSpec) -> int:
    """How many AGVs take tasks: every one, or with ``cfg.wait_limit`` the largest
    fleet whose wait bound is within it (``bound`` is the whole fleet's).

    Raises:
        ValueError: the limit is below one AGV's own latency, or the vehicles have
            batteries (a reserve AGV would drive to charge).
    """
    limit = cfg.wait_limit
    if limit is None:
        return cfg.agvs
    if spec.battery is not None:
        raise ValueError("a wait limit does not go together with batteries yet")
    active = bound.fleet_within(limit)
    if active < 1:
        raise ValueError(
            f"wait_limit {limit:g} s is below one AGV's own latency, "
            f"{bound.latency_s:.1f} s: no fleet waits that little"
        )
    return min(cfg.agvs, active)


@dataclass(frozen=True, slots=True)
class FleetTasks:
    """Who takes tasks and how they come.

    Attributes:
        active: how many AGVs take tasks, the first by id (:func:`active_fleet`).
        interval: mean seconds between new tasks (None: the layout makes none).
        start: tasks created at the start.
    """

    active: int
    interval: float | None
    start: int


def fleet_tasks(
    cfg: FleetConfig, layout: Layout, spec: VehicleSpec, bound: WaitBound
) -> FleetTasks:
    """The AGVs that take tasks (``bound``: the whole fleet's wait bound) and the task
    stream they get (:func:`fleet_task_stream`)."""
    active = active_fleet(cfg, bound, spec)
    interval, start = fleet_task_stream(cfg, layout, spec, active)
    return FleetTasks(active, interval, start)


def fleet_agv_config(cfg: FleetConfig) -> AgvConfig:
    """The AGV components' tunables a fleet configuration sets."""
    return AgvConfig(
        t_update=cfg.t_update, dwell=cfg.dwell, broadcast=cfg.broadcast, advance_m=cfg.advance_m
    )


def fleet_task_stream(
    cfg: FleetConfig, layout: Layout, spec: VehicleSpec, agvs: int | None = None
) -> tuple[float | None, int]:
    """``(interval, start)``: mean seconds between new tasks (``cfg.task_interval``,
    else from the load and the layout; None: the layout has no stations to make any)
    and the tasks created at the start (``cfg.start_task_count``, at most as many as
    the layout keeps busy at the load, :func:`floor_vehicles`, each drive a
    :func:`~agv_app.tasks.load.standstill_pass` and the stations calling as ``cfg`` has
    them; with ``load_of="fleet"`` the fleet's rate and count alone). ``agvs``: those
    taking tasks (None: all)."""
    agvs = cfg.agvs if agvs is None else agvs
    if not pick_stations(layout):
        return cfg.task_interval, cfg.start_task_count(agvs)
    speed = spec.max_speed_m_s
    floor = math.inf  # the fleet's own rate, or a rate the configuration gives
    if cfg.load_of == "carried" and cfg.task_interval is None:
        rules = fleet_floor_rules(
            spec,
            t_update=cfg.t_update,
            step_s=cfg.dt,
            one_at_a_time=cfg.one_at_a_time,
            wait_for_drop=cfg.wait_for_drop,
        )
        floor = floor_vehicles(layout, speed_m_s=speed, dwell_s=cfg.dwell, rules=rules)
    start = cfg.start_task_count(min(floor, agvs))
    if cfg.task_interval is not None:
        return cfg.task_interval, start
    interval = task_interval_for_load(
        layout, agvs=agvs, load=cfg.load, speed_m_s=speed, dwell_s=cfg.dwell, floor=floor
    )
    return interval, start


def fleet_desk(
    cfg: FleetConfig,
    layout: Layout,
    *,
    rng: random.Random,
    clock: Callable[[], float],
    tally: MessageTally,
    on_created: Callable[[TaskSpec, float], None],
    store: TaskJournal | None,
) -> TaskDesk:
    """The fleet's task desk, as ``cfg`` says (its stations not open yet)."""
    return TaskDesk(
        layout,
        rng=rng,
        clock=clock,
        station_range=cfg.station_range,
        tally=tally,
        on_created=on_created,
        max_open=limit_for(cfg.max_open_tasks, layout, cfg.agvs),
        one_at_a_time=cfg.one_at_a_time,
        wait_for_drop=cfg.wait_for_drop,
        store=store,
    )


def open_bases(desk: TaskDesk, net: SimulatedNetwork, *, station_nodes: bool) -> None:
    """Open the desk's stations on new nodes of ``net``: one transport base
    (:data:`~agv_app.tasks.desk.BASE_ID`), or with ``station_nodes`` one node per pick
    station, ``st:<station id>``."""
    if station_nodes:
        for sid in pick_stations(desk.layout):
            desk.open_base(net.add_node(f"st:{sid}"), [sid])
    else:
        desk.open_base(net.add_node(BASE_ID))


def take_over(old: AgvController, agv: AgvController) -> None:
    """A restarted AGV's new component takes back the task its old one held, loaded if
    it was on its way to the drop (:mod:`agv_app.vehicle.comeback`)."""
    held = old.task or old.pending_task
    if held is not None:
        hand_back(agv, held, loaded=old.task is not None and old.phase in ("to_drop", "at_drop"))
