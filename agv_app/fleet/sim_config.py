"""How a simulated fleet runs: :class:`FleetConfig`, its checks, and what follows from it
alone (the tasks at the start).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from agv_app.fleet.liveness import REST_BEAT_S
from agv_app.fleet.stalls import STALL_LIMIT_S
from agv_app.tasks.admission import CROWDED
from agv_app.tasks.load import DEFAULT_LOAD, check_load, initial_tasks
from agv_app.vehicle.battery import BatterySpec
from agv_app.vehicle.controller import DEFAULT_ADVANCE_M

__all__ = ["LOAD_OF", "TRAFFIC_MODES", "FleetConfig"]

LOAD_OF = ("carried", "fleet")
"""What a fleet's ``load`` is a share of (:class:`FleetConfig`)."""

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
        load: target share of what the AGVs and the floor carry, in (0, 1]; the task
            rate follows from it, the fleet and the layout (:mod:`agv_app.tasks.load`)
            unless ``task_interval`` is given.
        load_of: ``"carried"``, the default: ``load`` is a share of what the fleet and
            its floor carry, the less; ``"fleet"``: of what the fleet carries alone, past
            what the floor carries where that is less (runs that mean to make AGVs
            queue: the random floors, the saturation benchmarks).
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
        wait_limit: the longest wait accepted, seconds: only the largest fleet whose
            wait bound is within it takes tasks (``WaitBound.fleet_within``), the first
            AGVs by id; the others stay parked at home, out of service, as a reserve
            that never moves, and the bound counts the AGVs in service (docs/traffic.md,
            "Bounded waits"). None: every AGV takes tasks.
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
    load_of: str = "carried"
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
    wait_limit: float | None = None

    def __post_init__(self) -> None:
        check_load(self.load)
        if self.load_of not in LOAD_OF:
            raise ValueError(f"load_of must be one of {LOAD_OF}, got {self.load_of!r}")
        if self.traffic not in TRAFFIC_MODES:
            raise ValueError(f"traffic must be one of {TRAFFIC_MODES}, got {self.traffic!r}")
        if self.task_interval is not None and not (
            self.task_interval > 0 and math.isfinite(self.task_interval)
        ):
            raise ValueError(f"task_interval must be a positive number, got {self.task_interval!r}")
        if self.wait_limit is not None and self.batteries is not None:
            raise ValueError(
                "wait_limit and batteries do not go together yet: a reserve AGV would "
                "drive to a charger, and the wait bound counts only the AGVs in service"
            )
        for name in (
            "interest_radius",
            "heartbeat",
            "republish",
            "rest_beat",
            "advance_m",
            "wait_limit",
        ):
            value = getattr(self, name)
            if value is not None and not (value > 0 and math.isfinite(value)):
                raise ValueError(f"{name} must be a positive number, got {value!r}")
        if self.start_tasks is not None and self.start_tasks < 0:
            raise ValueError(f"start_tasks must be 0 or more, got {self.start_tasks!r}")

    def start_task_count(self, floor: float = math.inf) -> int:
        """Tasks created at the start: ``start_tasks``, or when that is None about
        ``load * agvs`` (``load * floor`` if the layout keeps fewer than ``agvs``
        busy, :func:`~agv_app.tasks.load.floor_vehicles`) if the rate follows from the
        load and ``task_until`` is not 0, else none."""
        if self.start_tasks is not None:
            return self.start_tasks
        by_load = self.task_interval is None and (self.task_until is None or self.task_until > 0)
        return initial_tasks(agvs=self.agvs, load=self.load, floor=floor) if by_load else 0
