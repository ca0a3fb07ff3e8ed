"""The fleet simulation: AGVs, stations and an observer on one ``SimulatedNetwork``.

:class:`Fleet` steps every AGV every ``dt`` of virtual time, runs the safety monitor
after every step, creates transport tasks at random pick stations, and keeps the
metrics. It also implements the dashboard's ``FleetSource`` protocol (structurally:
the dashboard imports us, never the other way round).
"""

from __future__ import annotations

import dataclasses
import functools
import math
import random
from collections.abc import Callable, Collection, Mapping, Sequence
from dataclasses import dataclass

from agv_app.fleet.base import FleetSourceBase
from agv_app.fleet.blocks import FloorBlocks
from agv_app.fleet.chargers import Chargers
from agv_app.fleet.liveness import REPUBLISH_BEATS, REST_BEAT_S, fleet_liveness
from agv_app.fleet.metrics import FleetMetrics
from agv_app.fleet.parking import ParkingPlan, home_heading
from agv_app.fleet.stalls import STALL_LIMIT_S, StallWatch
from agv_app.fleet.view import OBSERVER_ID, VehicleState, area_rings
from agv_app.geometry import XY, Area, Pose
from agv_app.layout.demo import DEMO_VEHICLE_LENGTH_M, DEMO_VEHICLE_WIDTH_M, demo_warehouse
from agv_app.layout.graph import Layout
from agv_app.samples import percentile
from agv_app.tasks.admission import CROWDED, limit_for
from agv_app.tasks.desk import BASE_ID, TaskDesk, pick_stations, require_task_stations
from agv_app.tasks.free_flow import FreeFlowBound, FreeFlowTimer
from agv_app.tasks.journal import TaskJournal
from agv_app.tasks.load import (
    DEFAULT_LOAD,
    TaskArrivals,
    check_load,
    initial_tasks,
    task_interval_for_load,
)
from agv_app.traffic.central import CentralScheduler
from agv_app.traffic.monitor import SafetyMonitor, SafetyViolation
from agv_app.traffic.reach import dissemination_margin, interest_radius
from agv_app.traffic.stale_relay import StaleListener, StaleRelay
from agv_app.traffic.wait_bound import WaitBound, wait_bound
from agv_app.vehicle.battery import BatterySpec
from agv_app.vehicle.comeback import hand_back
from agv_app.vehicle.controller import DEFAULT_ADVANCE_M, AgvConfig, AgvController
from agv_app.vehicle.driven import planning_spec
from agv_app.vehicle.driver import VehicleDriver
from agv_app.vehicle.kinematics import VehicleSpec
from agv_app.vehicle.service import send_home
from objectplaces import RoleActivator
from objectplaces.core.config import NodeConfig
from objectplaces.core.spatial import MAX_SCOPE_CELLS, footprint_cells
from objectplaces.runtime.sim import collections_spaced
from objectplaces.sim import SimulatedNetwork

__all__ = ["TRAFFIC_MODES", "DriverFactory", "Fleet", "FleetConfig", "SafetyError"]

DriverFactory = Callable[[str, Pose], VehicleDriver]
"""Builds an AGV's driver: ``(agv id, where it stands at first)``; asked again when the
AGV's process restarts (:meth:`Fleet.reboot`), when a driver that keeps its pose
(``SimDriver.recovered``) finds it where it stood."""

TRAFFIC_MODES = ("protocol", "central")
"""How locks are granted: by the AGVs' collision groups, or by one central scheduler."""


@dataclass(frozen=True, slots=True)
class FleetConfig:
    """How a fleet runs (seconds and metres).

    Attributes:
        agvs: number of AGVs.
        seed: seeds the network and the task generator.
        dt: simulation step.
        t_update: property update interval; the safe time is twice this. It is the
            heartbeat too, unless ``heartbeat`` is given.
        delay: one-way network delay.
        jitter: delay variation.
        jitter_per_frame: a frame reaches all its receivers at one instant (its jitter
            drawn once, as on a shared radio medium; docs/sim-speed.md), unless loss,
            duplication or reordering is asked for; False: each receiver's on its own.
        loss: frame loss probability.
        reorder: probability a frame is held back (reordering).
        duplicate: probability a frame is duplicated.
        broadcast: vote with every AGV instead of the collision group.
        traffic: ``"protocol"`` (the AGVs' own collision groups) or ``"central"`` (one
            scheduler grants every lock, :mod:`agv_app.traffic.central`).
        scoped: with collision groups, each AGV node hears only the nodes within its
            interest radius (:func:`agv_app.traffic.reach.interest_radius`); stations
            and the observer hear every node. Broadcast runs are never scoped.
        interest_radius: the AGVs' interest radius when scoped (None: from the layout).
        footprints: when scoped, each AGV publishes to the cells its own circle reaches
            (its hull length plus half the dissemination margin) and listens over the
            largest hull length plus the other half, instead of publishing in its own
            cell and listening over twice the largest (``NodeConfig.footprint_margin``).
        heartbeat: the liveness interval (None: ``t_update``): a node that has published
            nothing for this long sends a beat of a few bytes (``NodeConfig.beat_interval``);
            a node unheard for three heartbeats counts as failed.
        republish: seconds between republications of every property, the last resort
            against lost updates (None: ``REPUBLISH_BEATS`` heartbeats; a loss is found by
            the next frame of the node, publications being numbered without gaps).
        rest_beat: an AGV parked at its home with no task is at rest and beats only this
            often (``NodeConfig.rest_beat_interval``; its heartbeat when that is longer),
            and so do the transport base and the observer, which never move; their
            peers count them failed after three of these. None: no rest. The interest
            radius allows for the longer wait (docs/traffic.md, "Idle AGVs").
        beats: False: no beats; every node republishes every property each heartbeat
            instead (how the fleet ran before beats; ``republish`` is then ignored).
        probes: False: no node probes the idle members of its sessions
            (``NodeConfig.probe_interval``; how the fleet ran before probes).
        station_nodes: each pick station's component on a node of its own,
            ``st:<station id>``, as where every station is a computer of its own; False:
            one transport base (``BASE_ID``) runs them all, and every AGV's properties
            reach one listener for all the stations (docs/fleet.md, "The transport
            base").
        load: target share of busy AGVs, in (0, 1]; the task rate follows from it and
            the layout (:mod:`agv_app.tasks.load`) unless ``task_interval`` is given.
        task_interval: mean seconds between new tasks (None: from ``load``).
        start_tasks: tasks created at the start (None: about ``load * agvs`` when the
            rate follows from the load and ``task_until`` is not 0, else none).
        task_until: no new tasks after this time (None: never).
        max_open_tasks: tasks on the floor at once, at most (handed to the stations and
            not yet done); the others wait at the desk, oldest first (``"auto"``: a
            limit that follows the floor's long waits,
            :class:`~agv_app.tasks.admission.AdaptiveLimit`; None: no limit;
            :data:`~agv_app.tasks.admission.CROWDED`, the default: ``"auto"`` for a
            fleet larger than its floor carries, else none;
            :class:`~agv_app.tasks.desk.TaskDesk`).
        one_at_a_time: a station calls one AGV at a time: it auctions its next task
            once the last winner has reached it and no AGV is bound to drop there
            (:class:`~agv_app.tasks.station.Station`).
        wait_for_drop: with ``one_at_a_time``, a station holds a task whose drop
            station an AGV is bound for already.
        deadlock_after: an AGV stalled this long counts as a deadlock.
        station_range: first auction range of the stations.
        dwell: seconds at a pick or drop station.
        advance_m: how far beyond its locks an AGV's request reaches at least
            (``AgvConfig.advance_m``; the interest radius follows it).
        fail_on_violation: raise at the first safety violation.
        batteries: every AGV's battery (None: none, unless the vehicle spec declares
            one): they drain, charge at the layout's chargers and may run empty
            (:mod:`agv_app.fleet.chargers`).
    """

    agvs: int = 20
    seed: int = 1
    dt: float = 0.1
    t_update: float = 1.0
    delay: float = 0.005
    jitter: float = 0.002
    jitter_per_frame: bool = True
    loss: float = 0.0
    reorder: float = 0.0
    duplicate: float = 0.0
    broadcast: bool = False
    traffic: str = "protocol"
    scoped: bool = True
    interest_radius: float | None = None
    footprints: bool = True
    heartbeat: float | None = None
    republish: float | None = None
    rest_beat: float | None = REST_BEAT_S
    beats: bool = True
    probes: bool = True
    station_nodes: bool = False
    load: float = DEFAULT_LOAD
    task_interval: float | None = None
    start_tasks: int | None = None
    task_until: float | None = None
    max_open_tasks: int | str | None = CROWDED
    one_at_a_time: bool = True
    wait_for_drop: bool = True
    deadlock_after: float = STALL_LIMIT_S
    station_range: float = 30.0
    dwell: float = 5.0
    advance_m: float = DEFAULT_ADVANCE_M
    fail_on_violation: bool = False
    batteries: BatterySpec | None = None

    def __post_init__(self) -> None:
        check_load(self.load)
        if self.traffic not in TRAFFIC_MODES:
            raise ValueError(f"traffic must be one of {TRAFFIC_MODES}, got {self.traffic!r}")
        if self.task_interval is not None and not (
            self.task_interval > 0 and math.isfinite(self.task_interval)
        ):
            raise ValueError(f"task_interval must be a positive number, got {self.task_interval!r}")
        for name in ("interest_radius", "heartbeat", "republish", "rest_beat", "advance_m"):
            value = getattr(self, name)
            if value is not None and not (value > 0 and math.isfinite(value)):
                raise ValueError(f"{name} must be a positive number, got {value!r}")
        if self.start_tasks is not None and self.start_tasks < 0:
            raise ValueError(f"start_tasks must be 0 or more, got {self.start_tasks!r}")


def _insert_after(figures: dict[str, float], key: str, more: dict[str, float]) -> dict[str, float]:
    keys = list(figures)
    at = keys.index(key) + 1
    return {k: figures[k] for k in keys[:at]} | more | {k: figures[k] for k in keys[at:]}


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
        vehicle: builds each AGV component, with the arguments of
            :class:`~agv_app.vehicle.controller.AgvController` (e.g. one that also
            follows VDA 5050 orders).
        drivers: builds each AGV's driver (None: the simulated kinematics). A driver
            failure takes the AGV's node off the network, as a goodbye (its peers keep
            its last circle); the safety monitor checks the hull a driver says the
            vehicle truly has (``true_hull()``), where it has one.
        store: the durable order book the task desk writes through to and resumes from
            (:class:`~agv_app.tasks.store.OrderStore`; None: none).
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
        self._vehicle = vehicle
        self._drivers = drivers
        self._node_liveness = liveness = self._liveness()
        self.net = SimulatedNetwork(
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
        self.rng = random.Random(cfg.seed)
        self.metrics_raw = FleetMetrics()
        self.monitor = SafetyMonitor()
        # The desk is made below; the watch tells it of long waits once the fleet runs.
        self.stalls = StallWatch(
            limit_s=cfg.deadlock_after, on_long_wait=lambda _agv, now: self.desk.long_wait(now)
        )
        self.step_count = 0
        self._speed = 1.0
        self._carry = 0.0
        if pick_stations(self.layout):
            require_task_stations(self.layout)  # tasks can be asked for: can they be made?
        self.parking = ParkingPlan(self.layout, self.spec, cfg.agvs, homes=homes)
        width = max(2, len(str(cfg.agvs)))
        ids = [f"agv-{i + 1:0{width}d}" for i in range(len(self.parking.homes))]
        firsts = [
            home if starts is None else starts[i] for i, home in enumerate(self.parking.homes)
        ]
        poses = [
            self._pose_at(point, None if headings is None else headings[i])
            for i, point in enumerate(firsts)
        ]
        built = [
            None if drivers is None else drivers(a, pose)
            for a, pose in zip(ids, poses, strict=True)
        ]
        self.plan_spec = self.spec
        """The widest of the AGVs' planning specs (their drivers' declarations): what the
        interest radius allows for."""
        for driver in built:
            if driver is not None:
                self.plan_spec = _widest(self.plan_spec, planning_spec(self.spec, driver.limits))
        self._truths: dict[str, Callable[[], Area]] = {}
        self.free_flow = FreeFlowBound(
            FreeFlowTimer(self.layout, self.spec.max_speed_m_s, cfg.dwell), self.parking.homes
        )
        self.task_interval: float | None = cfg.task_interval
        """Mean seconds between new tasks (None: the layout has no stations to make any)."""
        if self.task_interval is None and pick_stations(self.layout):
            self.task_interval = task_interval_for_load(
                self.layout,
                agvs=cfg.agvs,
                load=cfg.load,
                speed_m_s=self.spec.max_speed_m_s,
                dwell_s=cfg.dwell,
            )
        super().__init__(
            self.layout,
            TaskDesk(
                self.layout,
                rng=self.rng,
                clock=lambda: self.net.now,
                station_range=cfg.station_range,
                tally=self.metrics_raw.tally,
                on_created=self.free_flow.add,
                max_open=limit_for(cfg.max_open_tasks, self.layout, cfg.agvs),
                one_at_a_time=cfg.one_at_a_time,
                wait_for_drop=cfg.wait_for_drop,
                store=store,
            ),
        )
        self.agv_config = AgvConfig(
            t_update=cfg.t_update,
            dwell=cfg.dwell,
            broadcast=cfg.broadcast,
            advance_m=cfg.advance_m,
        )
        self.interest_radius = self._interest_radius()
        """The AGV nodes' interest radius (None: they hear every node)."""
        self.footprint_margin = self._footprint_margin()
        """The AGV nodes' footprint margin (None: they publish in their own cell)."""
        self.central = CentralScheduler() if cfg.traffic == "central" else None
        self.agvs: dict[str, AgvController] = {}
        self.blocks = FloorBlocks(self.layout, self.agvs)
        """The parts of the floor the operator closed (:mod:`agv_app.fleet.blocks`)."""
        self._left: set[str] = set()
        for agv_id, home, start, pose, driver in zip(
            ids, self.parking.homes, firsts, poses, built, strict=True
        ):
            self._build(agv_id, home, start, pose, driver)
            self.parking.claim(agv_id, home)
        battery = self.spec.battery
        self.chargers = None if battery is None else Chargers(battery, self.parking, self.agvs)
        """The AGVs' batteries and the chargers (None: no battery model)."""
        if cfg.station_nodes:
            for sid in pick_stations(self.layout):
                self.desk.open_base(self.net.add_node(f"st:{sid}"), [sid])
        else:
            self.desk.open_base(self.net.add_node(BASE_ID))
        self.observer = self.net.add_node(OBSERVER_ID)
        self.observer.set_at_rest(True)  # it listens; it speaks only of failed AGVs
        self.stale_relay = None if self.interest_radius is None else StaleRelay(self.observer)
        """Relays failed AGVs to every AGV when the AGVs are scoped (traffic/stale_relay.py)."""
        start_tasks = cfg.start_tasks
        if start_tasks is None:
            by_load = cfg.task_interval is None and (cfg.task_until is None or cfg.task_until > 0)
            start_tasks = initial_tasks(agvs=cfg.agvs, load=cfg.load) if by_load else 0
        for _ in range(start_tasks):
            self.desk.create_random()
        self.arrivals = (
            None if self.task_interval is None else TaskArrivals(self.task_interval, self.rng)
        )
        self._next_task_at = self._draw_interval()

    def _pose_at(self, point: str, heading: float | None) -> Pose:
        p = self.layout.point(point)
        return Pose(p.x, p.y, home_heading(self.layout, point) if heading is None else heading)

    def _build(
        self, agv_id: str, home: str, start: str, pose: Pose, driver: VehicleDriver | None
    ) -> AgvController:
        """An AGV component on a new node (with ``driver``, standing where it says)."""
        node = self.net.add_node(
            agv_id, interest_radius=self.interest_radius, footprint_margin=self.footprint_margin
        )
        extra: dict[str, VehicleDriver] = {} if driver is None else {"driver": driver}
        agv = self._vehicle(
            node,
            self.layout,
            self.spec,
            home,
            start=start,
            heading_rad=pose.heading_rad,
            config=self.agv_config,
            tally=self.metrics_raw.tally,
            on_task_started=functools.partial(self._task_started, agv_id),
            on_task_done=self._task_done,
            on_lock_wait=self.metrics_raw.lock_waits.append,
            on_last_resort=self.metrics_raw.last_resort,
            relocate=self._relocate,
            central=self.central,
            **extra,
        )
        truth = getattr(driver, "true_hull", None)
        self._truths.pop(agv_id, None)
        if callable(truth):
            self._truths[agv_id] = truth
        self.agvs[agv_id] = agv
        agv.ways = self.blocks.ways
        self._listen(agv_id, node)
        return agv

    def _interest_radius(self) -> float | None:
        cfg = self.config
        if cfg.broadcast or not cfg.scoped:
            return None
        if cfg.interest_radius is not None:
            return cfg.interest_radius
        radius = interest_radius(
            self.layout,
            self.plan_spec,
            self.agv_config,
            footprints=cfg.footprints,
            **self._timing(),
        )
        # A floor whose runs are so long that the square of cells about the radius is more
        # than a node may subscribe to: every node hears every node, which is always safe.
        if footprint_cells(radius, 0.0, self.net.cell_size) > MAX_SCOPE_CELLS:
            return None
        return radius

    def _footprint_margin(self) -> float | None:
        if self.interest_radius is None or not self.config.footprints:
            return None
        # Half the margin on each side: the interest radius carries the other half.
        return dissemination_margin(self.plan_spec, self.agv_config, **self._timing()) / 2

    def _liveness(self) -> NodeConfig:
        """The nodes' liveness settings: heartbeat, republication, rest, timeout."""
        cfg = self.config
        heartbeat = cfg.t_update if cfg.heartbeat is None else cfg.heartbeat
        republish = heartbeat * REPUBLISH_BEATS if cfg.republish is None else cfg.republish
        return fleet_liveness(
            heartbeat, republish=republish if cfg.beats else None, rest_beat=cfg.rest_beat
        )

    def _timing(self) -> dict[str, float]:
        """The network delay and failure detection the dissemination margin allows for."""
        cfg = self.config
        # A held-back frame waits up to four more delays (SimulatedNetwork's reorder).
        worst_delay = (cfg.delay + cfg.jitter) * (5 if cfg.reorder else 1)
        detection = self._node_liveness.failure_detection_bound
        assert detection is not None  # the fleet's nodes always detect failures
        return {"delay_s": worst_delay, "failure_detection_s": detection}

    @functools.cached_property
    def wait_bound(self) -> WaitBound:
        """The longest any AGV of this fleet waits, from the layout and the fleet
        (docs/traffic.md, "Bounded waits"); its ``seconds`` is the figure
        ``wait_bound``."""
        return wait_bound(
            self.layout,
            self.spec,
            self.agv_config,
            agvs=self.config.agvs,
            delay_s=self._timing()["delay_s"],
            step_s=self.config.dt,
        )

    def _relocate(self, agv: AgvController) -> str | None:
        """A free rest point for an idle AGV that stands in the way (nearest ahead).

        Rest points are the fleet's to hand out, like a warehouse's parking plan; one
        bound for or on a charger stays.
        """
        if self.chargers is not None and self.chargers.stays(agv.node_id):
            return None
        return self.parking.relocate(agv.node_id, agv.home, agv.point)

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
        self.net.remove_node(agv_id)
        self.agvs[agv_id].fail()

    def recover(self, agv_id: str) -> None:
        """Bring a crashed AGV back on a fresh node."""
        node = self.net.add_node(
            agv_id, interest_radius=self.interest_radius, footprint_margin=self.footprint_margin
        )
        self._left.discard(agv_id)
        self.agvs[agv_id].restart(node)
        self._listen(agv_id, node)

    def reboot(self, agv_id: str) -> AgvController:
        """Restart a crashed AGV's process: a new component on a fresh node, its vehicle
        where the driver (asked anew, ``drivers``) says it stands, the task it held
        handed back (:mod:`agv_app.vehicle.comeback`).

        Raises:
            ValueError: the fleet has no ``drivers``, or the AGV has not crashed.
        """
        old = self.agvs[agv_id]
        if self._drivers is None or not old.failed:
            raise ValueError(f"{agv_id} cannot reboot: no drivers, or it has not crashed")
        self._left.discard(agv_id)
        home = old.home
        driver = self._drivers(agv_id, self._pose_at(home, None))
        agv = self._build(agv_id, home, home, self._pose_at(home, None), driver)
        held = old.task or old.pending_task
        if held is not None:
            hand_back(
                agv, held, loaded=old.task is not None and old.phase in ("to_drop", "at_drop")
            )
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
        chargers = self.chargers
        for agv_id, agv in self.agvs.items():
            if self.holds.held(agv_id) or (chargers is not None and chargers.empty(agv_id)):
                agv.hold()
            else:
                agv.release()
            if not self.holds.in_service(agv_id):
                agv.take_out_of_service()  # hands back a task it has not loaded
            agv.in_service = self._takes_tasks(agv_id)

    def _send_home(self, vehicle_id: str) -> str | None:
        """Send the AGV home at once (it is in this process)."""
        return send_home(self.agvs[vehicle_id])

    def _takes_tasks(self, agv_id: str) -> bool:
        """Whether the AGV may take tasks: the operator has it in service and its battery
        needs no charge."""
        chargers = self.chargers
        return self.holds.in_service(agv_id) and (chargers is None or chargers.takes_tasks(agv_id))

    def _listen(self, agv_id: str, node: RoleActivator) -> None:
        """A scoped AGV takes the failed AGVs the observer relays into its lock book."""
        if self.interest_radius is not None:
            agv = self.agvs[agv_id]
            StaleListener(node, lambda: agv.book)

    # -- running --------------------------------------------------------------------------

    def step(self) -> list[SafetyViolation]:
        """Advance one ``dt``: network, AGVs, tasks, monitor."""
        cfg = self.config
        dt = cfg.dt
        self.net.run_for(dt)
        now = self.net.now
        self.step_count += 1
        m = self.metrics_raw
        due = cfg.task_until is None or now < cfg.task_until
        if due and self.automatic_tasks and now >= self._next_task_at:
            self.desk.create_random()
            self._next_task_at = self._draw_interval()
        if self.central is not None:
            self.central.grant_waiting()
        for agv_id, agv in self.agvs.items():
            agv.step(dt)
            m.agv_seconds += dt
            if agv.failed:
                if agv.vehicle.fault is not None and agv_id not in self._left:
                    self._left.add(agv_id)
                    self.net.leave(agv_id)  # it says goodbye: the others keep its circle
                continue
            shown = agv.display_status()
            if shown == "idle":
                m.idle_seconds += dt
            elif shown == "waiting":
                m.waiting_seconds += dt
            self.stalls.observe(agv_id, stalled=agv.stalled, now=now)
        if self.chargers is not None:
            self._charge(dt, now)
        truths = self._truths
        hulls = [
            (a, truths[a]() if a in truths else agv.vehicle.hull()) for a, agv in self.agvs.items()
        ]
        # The areas alone: the monitor needs no direction claims, a lookup per lock.
        locks = [(a, area) for a, agv in self.agvs.items() for _, area in agv.book.lock_areas()]
        found = self.monitor.check(self.step_count, now, hulls, locks)
        if found and cfg.fail_on_violation:
            raise SafetyError("\n".join(str(v) for v in found))
        return found

    def _charge(self, dt: float, now: float) -> None:
        """Drain and charge the batteries; chargers to the AGVs that need one."""
        chargers = self.chargers
        assert chargers is not None
        for agv_id, agv in self.agvs.items():
            chargers.step(agv_id, agv, dt, now)
            agv.in_service = self._takes_tasks(agv_id)
        chargers.grant(self.agvs, now)

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
        stats = self.net.stats()
        agv_sent: dict[str, tuple[int, int]] = {}
        for agv_id in self.agvs:
            traffic = stats.per_node.get(agv_id)
            if traffic is None:
                continue
            for kind, (n, b) in traffic.sent.items():
                old = agv_sent.get(kind, (0, 0))
                agv_sent[kind] = (old[0] + n, old[1] + b)
        figures = self.metrics_raw.summary(
            tasks=self.desk.book,
            tasks_returned=self.desk.returned,
            tasks_refused=self.desk.refused,
            stalls=self.stalls,
            free_flow_tasks_per_hour=self.free_flow.per_hour(self.net.now),
            agvs=len(self.agvs),
            sim_seconds=self.net.now,
            wall_seconds=wall_seconds,
            collisions=self.monitor.collisions,
            lock_overlaps=self.monitor.lock_overlaps,
            messages=stats.messages,
            bytes_=stats.bytes,
            agv_sent=agv_sent,
        ) | ({} if self.chargers is None else self.chargers.stats.summary())
        # Beside the task times, their share of free flow; beside the longest wait, what
        # it may be at most.
        lead = {"lead_ratio_p95": round(percentile(self.lead_ratios(), 95), 3)}
        figures = _insert_after(figures, "task_time_p95", lead)
        return _insert_after(figures, "max_wait", {"wait_bound": round(self.wait_bound.seconds, 2)})

    def lead_ratios(self) -> list[float]:
        """Each delivered task's lead time (from its creation, time at the task desk
        included, to its delivery) over its free-flow lead time (the same in the
        free-flow replay, :class:`~agv_app.tasks.free_flow.FreeFlowBound`), for the
        tasks the book still holds in detail, oldest first."""
        ratios = []
        for record in self.desk.book.records():
            ideal = self.free_flow.lead_seconds(record.id)
            if record.state == "done" and ideal:
                ratios.append((record.times["done"] - record.times["created"]) / ideal)
        return ratios

    # -- FleetSource ------------------------------------------------------------------------

    def vehicles(self) -> Sequence[VehicleState]:
        """Every AGV, by id."""
        out = []
        chargers, now = self.chargers, self.net.now
        for agv_id, agv in sorted(self.agvs.items()):
            pose = agv.vehicle.pose()
            locks, request = agv.areas()
            hull = area_rings(agv.vehicle.hull())
            out.append(
                VehicleState(
                    agv_id,
                    pose.x,
                    pose.y,
                    pose.heading_rad,
                    self.spec.length_m,
                    self.spec.width_m,
                    self._shown(agv_id, agv),
                    agv.task.id
                    if agv.task
                    else (agv.pending_task.id if agv.pending_task else None),
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

    def _shown(self, agv_id: str, agv: AgvController) -> str:
        """The dashboard's status: ``charging``, ``to-charger`` or ``empty`` when the
        battery says so, else the AGV's own."""
        by_battery = None if self.chargers is None else self.chargers.status(agv_id)
        return by_battery or agv.display_status()

    def vehicle_route(self, vehicle_id: str) -> tuple[XY, ...]:
        """The rest of an AGV's route, from where it stands to where it stops; ``()`` at
        rest or failed.

        Raises:
            KeyError: no AGV has that id.
        """
        agv = self.agvs[vehicle_id]
        vehicle = agv.vehicle
        if agv.failed or vehicle.remaining() <= 1e-9:
            return ()
        return tuple(vehicle.route.slice(vehicle.s, vehicle.route.length).coords)

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
        if not (isinstance(factor, int | float) and factor > 0 and math.isfinite(factor)):
            raise ValueError(f"speed must be a positive number, got {factor!r}")
        self._speed = float(factor)

    @property
    def speed(self) -> float:
        """The factor last given to ``set_speed``."""
        return self._speed

    @property
    def now(self) -> float:
        """Simulated seconds since the start."""
        return self.net.now

    def advance(self, seconds: float) -> None:
        """Advance by ``seconds`` in whole steps (the remainder carries over)."""
        if seconds <= 0:
            return
        self._carry += seconds
        dt = self.config.dt
        while self._carry >= dt - 1e-9:
            self._carry -= dt
            self.step()


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
