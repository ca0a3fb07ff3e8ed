"""The fleet simulation: AGVs, stations and an observer on one ``SimulatedNetwork``.

:class:`Fleet` steps every AGV every ``dt`` of virtual time, runs the safety monitor
after every step, creates transport tasks at random pick stations, and keeps the
metrics. It also implements the dashboard's ``FleetSource`` protocol (structurally:
the dashboard imports us, never the other way round).

Its parts, in agv_app.fleet: sim_config (its configuration), sim_network (who hears
whom), sim_build (what it is built from), sim_agvs (the AGV components and their
nodes), sim_step (what a step does to the AGVs) and sim_view (what it shows).
"""

from __future__ import annotations

import dataclasses
import functools
import math
import random
from collections.abc import Callable, Collection, Mapping, Sequence

from agv_app.fleet.base import FleetSourceBase
from agv_app.fleet.blocks import FloorBlocks
from agv_app.fleet.chargers import Chargers
from agv_app.fleet.metrics import FleetMetrics
from agv_app.fleet.parking import ParkingPlan
from agv_app.fleet.sim_agvs import AgvNodes, DriverFactory
from agv_app.fleet.sim_build import (
    fleet_agv_config,
    fleet_desk,
    fleet_tasks,
    open_bases,
    place_agvs,
)
from agv_app.fleet.sim_config import TRAFFIC_MODES, FleetConfig
from agv_app.fleet.sim_network import (
    fleet_network,
    fleet_plan_spec,
    fleet_wait_bound,
    network_timing,
    node_liveness,
    scoped_footprint_margin,
    scoped_interest_radius,
)
from agv_app.fleet.sim_step import (
    Pace,
    apply_holds,
    charge,
    check_safety,
    drive_agvs,
    rest_point,
    takes_tasks,
)
from agv_app.fleet.sim_view import fleet_summary, route_ahead, task_lead_ratios, vehicle_states
from agv_app.fleet.stalls import StallWatch
from agv_app.fleet.view import OBSERVER_ID, VehicleState
from agv_app.geometry import XY
from agv_app.layout.demo import DEMO_VEHICLE_LENGTH_M, DEMO_VEHICLE_WIDTH_M, demo_warehouse
from agv_app.layout.graph import Layout
from agv_app.tasks.desk import pick_stations, require_task_stations
from agv_app.tasks.free_flow import FreeFlowBound, FreeFlowTimer
from agv_app.tasks.journal import TaskJournal
from agv_app.tasks.load import TaskArrivals
from agv_app.traffic.central import CentralScheduler
from agv_app.traffic.monitor import SafetyMonitor, SafetyViolation
from agv_app.traffic.stale_relay import StaleRelay
from agv_app.traffic.wait_bound import WaitBound
from agv_app.vehicle.controller import AgvController
from agv_app.vehicle.kinematics import VehicleSpec
from agv_app.vehicle.service import send_home
from objectplaces import RoleActivator
from objectplaces.runtime.sim import collections_spaced

__all__ = ["TRAFFIC_MODES", "DriverFactory", "Fleet", "FleetConfig", "SafetyError"]


class SafetyError(AssertionError):
    """A safety violation in a run that must have none."""


class Fleet(FleetSourceBase):
    """A simulated fleet on a layout.

    Args:
        layout: the floor plan (default: the demo warehouse).
        config: how it runs.
        spec: the vehicles' size and limits.
        homes: each AGV's parking point (default: spread over the parking stations).
        starts: where each AGV stands at first (default: its home).
        headings: each AGV's first heading (default: along the way into its spot).
        vehicle: builds each AGV component, with ``AgvController``'s arguments (e.g.
            one that also follows VDA 5050 orders).
        drivers: builds each AGV's driver (None: the simulated kinematics). A failed
            driver takes the AGV's node off the network, as a goodbye; the safety
            monitor checks the hull a driver says the vehicle has (``true_hull()``).
        store: the durable order book the desk writes through to and resumes from.
    """

    def __init__(
        self,
        layout: Layout | None = None,
        config: FleetConfig | None = None,
        *,
        spec: VehicleSpec | None = None,
        homes: Sequence[str] | None = None,
        starts: Sequence[str] | None = None,
        headings: Sequence[float] | None = None,
        vehicle: Callable[..., AgvController] = AgvController,
        store: TaskJournal | None = None,
        drivers: DriverFactory | None = None,
    ) -> None:
        self.layout = layout or demo_warehouse()
        self.config = cfg = config or FleetConfig()
        self.spec = spec or VehicleSpec(DEMO_VEHICLE_LENGTH_M, DEMO_VEHICLE_WIDTH_M)
        if cfg.batteries is not None:
            self.spec = dataclasses.replace(self.spec, battery=cfg.batteries)
        self._node_liveness = liveness = node_liveness(cfg)
        self.net = fleet_network(cfg, liveness)
        self.rng = random.Random(cfg.seed)
        self.metrics_raw = FleetMetrics()
        self.monitor = SafetyMonitor()
        # The desk is made below; the watch tells it of long waits once the fleet runs.
        self.stalls = StallWatch(
            limit_s=cfg.deadlock_after, on_long_wait=lambda _agv, now: self.desk.long_wait(now)
        )
        self.step_count = 0
        self._pace = Pace(cfg.dt)
        if pick_stations(self.layout):
            require_task_stations(self.layout)  # tasks can be asked for: can they be made?
        self.parking = ParkingPlan(self.layout, self.spec, cfg.agvs, homes=homes)
        placed = place_agvs(
            self.layout, self.parking.homes, cfg.agvs, starts=starts, headings=headings
        )
        built = [
            None if drivers is None else drivers(a, pose)
            for a, pose in zip(placed.ids, placed.poses, strict=True)
        ]
        self.plan_spec = fleet_plan_spec(self.spec, built)
        """The widest of the AGVs' planning specs: what the interest radius allows for."""
        self.agv_config = fleet_agv_config(cfg)
        everyone = fleet_wait_bound(cfg, self.layout, self.spec, self.agv_config, liveness)
        tasks = fleet_tasks(cfg, self.layout, self.spec, everyone)
        self.active = tasks.active
        """How many AGVs take tasks, the first by id (``FleetConfig.wait_limit``)."""
        timer = FreeFlowTimer(self.layout, self.spec.max_speed_m_s, cfg.dwell)
        self.free_flow = FreeFlowBound(timer, self.parking.homes[: tasks.active])
        self.task_interval = tasks.interval
        """Mean seconds between new tasks (None: the layout has no stations to make any)."""
        desk = fleet_desk(
            cfg,
            self.layout,
            rng=self.rng,
            clock=lambda: self.net.now,
            tally=self.metrics_raw.tally,
            on_created=self.free_flow.add,
            store=store,
        )
        super().__init__(self.layout, desk)
        timing = network_timing(cfg, liveness)
        self.interest_radius = scoped_interest_radius(
            cfg, self.layout, self.plan_spec, self.agv_config, timing, self.net.cell_size
        )
        """The AGV nodes' interest radius (None: they hear every node)."""
        self.footprint_margin = scoped_footprint_margin(
            cfg, self.interest_radius, self.plan_spec, self.agv_config, timing
        )
        """The AGV nodes' footprint margin (None: they publish in their own cell)."""
        self.central = CentralScheduler() if cfg.traffic == "central" else None
        self.agv_nodes = AgvNodes(
            self.net,
            self.layout,
            self.spec,
            vehicle,
            interest_radius=self.interest_radius,
            footprint_margin=self.footprint_margin,
            drivers=drivers,
            on_task_started=self._task_started,
            options={
                "config": self.agv_config,
                "tally": self.metrics_raw.tally,
                "on_task_done": self._task_done,
                "on_lock_wait": self.metrics_raw.lock_waits.append,
                "on_last_resort": self.metrics_raw.last_resort,
                "relocate": self._relocate,
                "central": self.central,
            },
        )
        """The AGV components and their nodes."""
        self.agvs = self.agv_nodes.agvs
        self.blocks = FloorBlocks(self.layout, self.agvs)
        """The parts of the floor the operator closed (:mod:`agv_app.fleet.blocks`)."""
        for agv_id, home, start, pose, driver in zip(
            placed.ids, self.parking.homes, placed.starts, placed.poses, built, strict=True
        ):
            self.agv_nodes.build(agv_id, home, start, pose, driver)
            self.parking.claim(agv_id, home)
        battery = self.spec.battery
        self.chargers = None if battery is None else Chargers(battery, self.parking, self.agvs)
        """The AGVs' batteries and the chargers (None: no battery model)."""
        open_bases(self.desk, self.net, station_nodes=cfg.station_nodes)
        self.observer = self.net.add_node(OBSERVER_ID)
        self.observer.set_at_rest(True)  # it listens; it speaks only of failed AGVs
        self.stale_relay = None if self.interest_radius is None else StaleRelay(self.observer)
        """Relays failed AGVs to every AGV when the AGVs are scoped (traffic/stale_relay.py)."""
        if self.active < cfg.agvs:  # the reserve: parked, out of service, never moving
            self.set_service(placed.ids[self.active :], in_service=False)
        for _ in range(tasks.start):
            self.desk.create_random()
        interval = self.task_interval
        self.arrivals = None if interval is None else TaskArrivals(interval, self.rng)
        self._next_task_at = self._draw_interval()

    @functools.cached_property
    def wait_bound(self) -> WaitBound:
        """The longest any AGV waits, from the layout and the AGVs in service
        (docs/traffic.md, "Bounded waits"); its ``seconds`` is the figure ``wait_bound``."""
        return fleet_wait_bound(
            self.config, self.layout, self.spec, self.agv_config, self._node_liveness, self.active
        )

    def _relocate(self, agv: AgvController) -> str | None:
        """A free rest point for an idle AGV in the way (``sim_step.rest_point``)."""
        return rest_point(self.parking, self.chargers, agv)

    def _draw_interval(self) -> float:
        if self.arrivals is None:
            return math.inf
        return self.arrivals.next_after(self.net.now)

    # -- tasks ----------------------------------------------------------------------------

    def create_task(self, station_id: str, drop: str | None = None) -> str:
        """Create a transport task at a pick station (``FleetSource``).

        Raises:
            KeyError: no station has that id.
            ValueError: the station does not hand out loads.
            BacklogFull: the desk holds as many open tasks as it takes.
        """
        return self.desk.create(station_id, drop)

    def _task_started(self, agv_id: str, task_id: str) -> None:
        self.desk.book.start(task_id, agv_id, now=self.net.now)

    def _task_done(self, task_id: str) -> None:
        self.desk.finish(task_id, now=self.net.now)

    # -- failures -------------------------------------------------------------------------

    def crash(self, agv_id: str) -> None:
        """Crash an AGV's node: it stops where it stands, its hull stays on the floor."""
        self.agv_nodes.crash(agv_id)

    def recover(self, agv_id: str) -> None:
        """Bring a crashed AGV back on a fresh node."""
        self.agv_nodes.recover(agv_id)

    def _send_home(self, vehicle_id: str) -> str | None:
        return send_home(self.agvs[vehicle_id])  # at once: it is in this process

    def reboot(self, agv_id: str) -> AgvController:
        """Restart a crashed AGV's process: a new component on a fresh node, its vehicle
        where the driver (asked anew, ``drivers``) says it stands, the task it held
        handed back (:mod:`agv_app.vehicle.comeback`).

        Raises:
            ValueError: the fleet has no ``drivers``, or the AGV has not crashed.
        """
        agv = self.agv_nodes.reboot(agv_id)
        agv.ways = self.blocks.ways
        if self.holds.held(agv_id):
            agv.hold()
        if self.chargers is not None:
            agv.battery = self.chargers.batteries[agv_id]  # the vehicle's, not a fresh one
        agv.in_service = self._takes_tasks(agv_id)
        return agv

    # -- holding (an operator's stop) -------------------------------------------------------

    def vehicle_ids(self) -> Collection[str]:
        """The ids of every AGV."""
        return self.agvs.keys()

    def _apply_holds(self) -> None:
        """Hold or release every AGV as ``holds`` says, at once (it is in this process)."""
        apply_holds(self.agvs, self.holds, self.chargers)

    def _takes_tasks(self, agv_id: str) -> bool:
        """Whether the AGV may take tasks (``sim_step.takes_tasks``)."""
        return takes_tasks(self.holds, self.chargers, agv_id)

    # -- running --------------------------------------------------------------------------

    def step(self) -> list[SafetyViolation]:
        """Advance one ``dt``: network, AGVs, tasks, monitor."""
        cfg = self.config
        dt = cfg.dt
        self.net.run_for(dt)
        now = self.net.now
        self.step_count += 1
        due = cfg.task_until is None or now < cfg.task_until
        if due and self.automatic_tasks and now >= self._next_task_at:
            self.desk.create_random()
            self._next_task_at = self._draw_interval()
        if self.central is not None:
            self.central.grant_waiting()
        drive_agvs(
            self.agvs,
            dt,
            now,
            metrics=self.metrics_raw,
            stalls=self.stalls,
            net=self.net,
            left=self.agv_nodes.left,
        )
        if self.chargers is not None:
            charge(self.agvs, self.chargers, self.holds, dt, now)
        found = check_safety(self.monitor, self.agvs, self.agv_nodes.truths, self.step_count, now)
        if found and cfg.fail_on_violation:
            raise SafetyError("\n".join(str(v) for v in found))
        return found

    def run(self, seconds: float, progress: Callable[[float], None] | None = None) -> None:
        """Run for ``seconds`` of simulated time (whole steps), reporting progress."""
        steps = round(seconds / self.config.dt)
        with collections_spaced():  # across steps, not only while the network runs
            for k in range(steps):
                self.step()
                if progress is not None and k % 50 == 0:
                    progress(self.net.now)
        if progress is not None:
            progress(self.net.now)

    def summary(self, wall_seconds: float = 0.0) -> dict[str, float]:
        """The run's figures (see ``FleetMetrics.summary``), with ``lead_ratio_p95``
        (:meth:`lead_ratios`) and ``wait_bound`` (:attr:`wait_bound`)."""
        return fleet_summary(
            self.net,
            self.agvs,
            self.metrics_raw,
            self.desk,
            stalls=self.stalls,
            free_flow=self.free_flow,
            monitor=self.monitor,
            chargers=self.chargers,
            wait_bound_s=self.wait_bound.seconds,
            wall_seconds=wall_seconds,
        )

    def lead_ratios(self) -> list[float]:
        """Each delivered task's lead time (from its creation, time at the task desk
        included, to its delivery) over its free-flow lead time (the same in the
        free-flow replay, :class:`~agv_app.tasks.free_flow.FreeFlowBound`), for the
        tasks the book still holds in detail, oldest first."""
        return task_lead_ratios(self.desk.book, self.free_flow)

    # -- FleetSource ------------------------------------------------------------------------

    def vehicles(self) -> Sequence[VehicleState]:
        """Every AGV, by id."""
        return vehicle_states(self.agvs, self.spec, self.chargers, self.net.now)

    def vehicle_route(self, vehicle_id: str) -> tuple[XY, ...]:
        """The rest of an AGV's route, from where it stands to where it stops; ``()`` at
        rest or failed.

        Raises:
            KeyError: no AGV has that id.
        """
        return route_ahead(self.agvs[vehicle_id])

    def nodes(self) -> Mapping[str, RoleActivator]:
        """Every live node: AGVs, the transport base and the observer."""
        return self.net.nodes

    def metrics(self) -> Mapping[str, float]:
        """Figures so far."""
        return self.summary()

    def set_speed(self, factor: float) -> None:
        """Simulated seconds per wall second.

        Raises:
            ValueError: ``factor`` is not positive.
        """
        self._pace.set_speed(factor)

    @property
    def speed(self) -> float:
        """The factor last given to ``set_speed``."""
        return self._pace.speed

    @property
    def now(self) -> float:
        """Simulated seconds since the start."""
        return self.net.now

    def advance(self, seconds: float) -> None:
        """Advance by ``seconds`` in whole steps (the remainder carries over)."""
        for _ in self._pace.steps(seconds):
            self.step()
