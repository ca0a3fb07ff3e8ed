"""The fleet simulation: AGVs, stations and an observer on one ``SimulatedNetwork``.

:class:`Fleet` steps every AGV every ``dt`` of virtual time, runs the safety monitor
after every step, creates transport tasks at random pick stations, and keeps the
metrics. It also implements the dashboard's ``FleetSource`` protocol (structurally:
the dashboard imports us, never the other way round); :func:`demo_source` builds the
fleet ``objectplaces demo`` shows.
"""

from __future__ import annotations

import argparse
import math
import random
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from agv_app.fleet.metrics import FleetMetrics
from agv_app.geometry import XY, Area
from agv_app.layout.demo import DEMO_VEHICLE_LENGTH_M, DEMO_VEHICLE_WIDTH_M, demo_warehouse
from agv_app.layout.graph import Layout
from agv_app.tasks.auction import TaskSpec
from agv_app.tasks.station import Station
from agv_app.traffic.monitor import SafetyMonitor, SafetyViolation
from agv_app.vehicle.controller import AgvConfig, AgvController
from agv_app.vehicle.kinematics import VehicleSpec
from objectplaces import Initiator, RoleActivator
from objectplaces.sim import SimulatedNetwork

if TYPE_CHECKING:
    from agv_app.fleet.mesh import MeshFleet

__all__ = ["Fleet", "FleetConfig", "VehicleState", "demo_source", "parking_capacity"]

OBSERVER_ID = "observer"
MESH_DEMO_TASK_INTERVAL_S = 90.0
"""Mean seconds between tasks for one AGV process of the mesh demo (divided by N)."""


@dataclass(frozen=True, slots=True)
class FleetConfig:
    """How a fleet runs (seconds and metres).

    Attributes:
        agvs: number of AGVs.
        seed: seeds the network and the task generator.
        dt: simulation step.
        t_update: property update interval (heartbeat); safe time is twice this.
        delay: one-way network delay.
        jitter: delay variation.
        loss: frame loss probability.
        reorder: probability a frame is held back (reordering).
        duplicate: probability a frame is duplicated.
        broadcast: vote with every AGV instead of the collision group.
        task_interval: mean seconds between new tasks (None: ``1200 / agvs``).
        task_until: no new tasks after this time (None: never).
        deadlock_after: an AGV stalled this long counts as a deadlock.
        station_range: first auction range of the stations.
        dwell: seconds at a pick or drop station.
        fail_on_violation: raise at the first safety violation.
    """

    agvs: int = 20
    seed: int = 1
    dt: float = 0.1
    t_update: float = 1.0
    delay: float = 0.005
    jitter: float = 0.002
    loss: float = 0.0
    reorder: float = 0.0
    duplicate: float = 0.0
    broadcast: bool = False
    task_interval: float | None = None
    task_until: float | None = None
    deadlock_after: float = 180.0
    station_range: float = 30.0
    dwell: float = 5.0
    fail_on_violation: bool = False


@dataclass(frozen=True, slots=True)
class VehicleState:
    """One AGV as the dashboard sees it (a ``VehicleView``)."""

    id: str
    x: float
    y: float
    heading_rad: float
    length_m: float
    width_m: float
    status: str
    task_id: str | None
    hull: tuple[XY, ...]
    hull_length: float
    locked: tuple[tuple[XY, ...], ...]
    requested: tuple[tuple[XY, ...], ...]


def _rings(area: Area | None) -> list[tuple[XY, ...]]:
    if area is None or area.is_empty:
        return []
    geom = area.geom
    parts = list(geom.geoms) if geom.geom_type == "MultiPolygon" else [geom]
    return [tuple((float(x), float(y)) for x, y in list(p.exterior.coords)[:-1]) for p in parts]


class SafetyError(AssertionError):
    """A safety violation in a run that must have none."""


class Fleet:
    """A simulated fleet on a layout.

    Args:
        layout: the floor plan (default: the demo warehouse).
        config: how it runs.
        spec: the vehicles' size and limits.
        homes: each AGV's parking point (default: spread over the parking stations).
        starts: where each AGV stands at first (default: its home).
        headings: each AGV's first heading (default: along the way into its spot).
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
    ) -> None:
        self.layout = layout or demo_warehouse()
        self.config = cfg = config or FleetConfig()
        self.spec = spec or VehicleSpec(DEMO_VEHICLE_LENGTH_M, DEMO_VEHICLE_WIDTH_M)
        self.net = SimulatedNetwork(
            cfg.seed,
            delay=cfg.delay,
            jitter=cfg.jitter,
            loss=cfg.loss,
            reorder=cfg.reorder,
            duplicate=cfg.duplicate,
            property_interval=cfg.t_update,
            failure_timeout=3 * cfg.t_update,
        )
        self.rng = random.Random(cfg.seed)
        self.metrics_raw = FleetMetrics()
        self.monitor = SafetyMonitor()
        self.step_count = 0
        self._paused = False
        self._speed = 1.0
        self._carry = 0.0
        self._task_seq = 0
        self._tasks: dict[str, tuple[float, str | None]] = {}
        self._done: set[str] = set()
        self._deadlocked: set[str] = set()
        self.agv_config = AgvConfig(t_update=cfg.t_update, dwell=cfg.dwell, broadcast=cfg.broadcast)
        self.agvs: dict[str, AgvController] = {}
        self.stations: dict[str, Station] = {}
        self._failed: set[str] = set()
        home_points = list(homes) if homes is not None else self._pick_homes(cfg.agvs)
        self._rest_pool = home_points + (
            [] if homes is not None else self._rest_points(home_points, max(4, cfg.agvs // 4))
        )
        self._resting: dict[str, str] = {}  # rest point -> AGV that owns it
        width = max(2, len(str(cfg.agvs)))
        for i, home in enumerate(home_points):
            agv_id = f"agv-{i + 1:0{width}d}"
            node = self.net.add_node(agv_id)
            self.agvs[agv_id] = AgvController(
                node,
                self.layout,
                self.spec,
                home,
                start=None if starts is None else starts[i],
                heading_rad=(
                    headings[i]
                    if headings is not None
                    else self._home_heading(home if starts is None else starts[i])
                ),
                config=self.agv_config,
                tally=self.metrics_raw.tally,
                on_task_done=self._task_done,
                on_lock_wait=self.metrics_raw.lock_waits.append,
                relocate=self._relocate,
            )
            self._resting[home] = agv_id
        for sid in self.layout.usable_stations():
            st = self.layout.station(sid)
            if st.kind not in ("pick", "pickdrop"):
                continue
            node = self.net.add_node(f"st:{sid}")
            p = self.layout.point(st.point)
            self.stations[sid] = Station(
                node,
                sid,
                (p.x, p.y),
                range_m=cfg.station_range,
                on_assigned=self._assigned,
                tally=self.metrics_raw.tally,
            )
        self._drops = [
            s
            for s in self.layout.usable_stations()
            if self.layout.station(s).kind in ("drop", "pickdrop")
        ]
        self.observer = self.net.add_node(OBSERVER_ID)
        self._next_task_at = self._draw_interval()

    # -- set-up -------------------------------------------------------------------------

    def _pick_homes(self, n: int) -> list[str]:
        layout = self.layout
        points: list[str] = []
        for kind in ("parking", "charging"):
            for st in layout.stations_of_kind(kind):
                if st.id in layout.usable_stations() and st.point not in points:
                    points.append(st.point)
        if len(points) < n:
            points += self._rest_points(points, n - len(points))
        if len(points) < n:
            raise ValueError(f"layout {layout.name!r} has room to park {len(points)} AGVs, not {n}")
        # Spread the fleet over the spots rather than packing one corner.
        return [points[(k * len(points)) // n] for k in range(n)]

    def _rest_points(self, taken: list[str], n: int) -> list[str]:
        """Up to ``n`` more points to park on, at least a hull diagonal from each other
        and from stations, for layouts without enough parking spots (openTCS demos):
        dead ends first, then points on lanes."""
        layout = self.layout
        usable = {layout.station(s).point for s in layout.usable_stations()}
        reach = layout.distances_from(min(usable)) if usable else {}
        gap = math.hypot(self.spec.length_m, self.spec.width_m) + 0.5
        chosen: list[str] = []
        occupied = [layout.point(p) for p in sorted({*taken, *usable})]
        candidates = sorted(
            (p for p in layout.points if p in reach and p not in usable and p not in taken),
            key=lambda p: (len(layout.neighbours(p)) > 1, p),
        )
        for pid in candidates:
            p = layout.point(pid)
            if all(math.hypot(p.x - q.x, p.y - q.y) >= gap for q in occupied):
                chosen.append(pid)
                occupied.append(p)
                if len(chosen) == n:
                    break
        return chosen

    def _relocate(self, agv: AgvController) -> str | None:
        """A free parking point for an idle AGV that stands in the way (nearest ahead).

        Parking points are the fleet's to hand out, like a warehouse's parking plan.
        """
        dist = self.layout.distances_from(agv.point)
        free = [p for p in self._rest_pool if p not in self._resting and p in dist]
        if not free:
            return None
        best = min(free, key=lambda p: (dist[p], p))
        self._resting.pop(agv.home, None)
        self._resting[best] = agv.node_id
        return best

    def _home_heading(self, point: str) -> float:
        p = self.layout.point(point)
        preds = [q for q in self.layout.neighbours(point) if point in self.layout.successors(q)]
        if not preds:
            return 0.0
        q = self.layout.point(preds[0])
        return math.atan2(p.y - q.y, p.x - q.x)

    def _draw_interval(self) -> float:
        mean = self.config.task_interval or 1200.0 / max(self.config.agvs, 1)
        return self.net.now + self.rng.expovariate(1.0 / mean)

    # -- tasks ----------------------------------------------------------------------------

    def create_task(self, station_id: str, drop: str | None = None) -> str:
        """Create a transport task at a pick station (``FleetSource``).

        Raises:
            KeyError: no station has that id.
            ValueError: the station does not hand out loads.
        """
        if station_id not in self.layout.stations:
            raise KeyError(f"unknown station {station_id!r}")
        station = self.stations.get(station_id)
        if station is None:
            raise ValueError(f"station {station_id!r} is not a pick station")
        if drop is None:
            choices = [d for d in self._drops if d != station_id]
            drop = choices[self.rng.randrange(len(choices))]
        self._task_seq += 1
        task = TaskSpec(f"task-{self._task_seq}", station_id, drop)
        self._tasks[task.id] = (self.net.now, None)
        self.metrics_raw.tasks_created += 1
        station.add_task(task)
        return task.id

    def _assigned(self, task: TaskSpec, agv: str) -> None:
        created, holder = self._tasks.get(task.id, (self.net.now, None))
        if holder is not None and holder not in self._failed and task.id not in self._done:
            self.metrics_raw.double_assignments += 1
        self._tasks[task.id] = (created, agv)

    def _task_done(self, task_id: str) -> None:
        if task_id in self._done:
            return
        self._done.add(task_id)
        created, _ = self._tasks.get(task_id, (self.net.now, None))
        self.metrics_raw.tasks_completed += 1
        self.metrics_raw.task_times.append(self.net.now - created)

    @property
    def open_tasks(self) -> list[str]:
        """Ids of tasks created and not completed."""
        return [t for t in self._tasks if t not in self._done]

    # -- failures -------------------------------------------------------------------------

    def crash(self, agv_id: str) -> None:
        """Crash an AGV's node: it stops where it stands, its hull stays on the floor."""
        self.net.remove_node(agv_id)
        self.agvs[agv_id].fail()
        self._failed.add(agv_id)

    def recover(self, agv_id: str) -> None:
        """Bring a crashed AGV back on a fresh node."""
        node = self.net.add_node(agv_id)
        self._failed.discard(agv_id)
        self.agvs[agv_id].restart(node)
        for station in self.stations.values():
            station.returned += 0

    # -- running --------------------------------------------------------------------------

    def step(self) -> list[SafetyViolation]:
        """Advance one ``dt``: network, AGVs, tasks, monitor."""
        cfg = self.config
        dt = cfg.dt
        self.net.run_for(dt)
        now = self.net.now
        self.step_count += 1
        m = self.metrics_raw
        if (cfg.task_until is None or now < cfg.task_until) and now >= self._next_task_at:
            if self.stations:
                sids = sorted(self.stations)
                self.create_task(sids[self.rng.randrange(len(sids))])
            self._next_task_at = self._draw_interval()
        for agv_id, agv in self.agvs.items():
            agv.step(dt)
            m.agv_seconds += dt
            if agv.failed:
                continue
            shown = agv.display_status()
            if shown == "idle":
                m.idle_seconds += dt
            elif shown == "waiting":
                m.waiting_seconds += dt
            if agv.stalled_for(now) > cfg.deadlock_after:
                if agv_id not in self._deadlocked:
                    self._deadlocked.add(agv_id)
                    m.deadlocks += 1
            else:
                self._deadlocked.discard(agv_id)
        hulls = [(a, agv.vehicle.hull()) for a, agv in self.agvs.items()]
        locks = [(a, e.area) for a, agv in self.agvs.items() for e in agv.book.locks()]
        found = self.monitor.check(self.step_count, now, hulls, locks)
        if found and cfg.fail_on_violation:
            raise SafetyError("\n".join(str(v) for v in found))
        return found

    def run(self, seconds: float, progress: Callable[[float], None] | None = None) -> None:
        """Run for ``seconds`` of simulated time (whole steps), reporting progress."""
        steps = round(seconds / self.config.dt)
        for k in range(steps):
            self.step()
            if progress is not None and k % 50 == 0:
                progress(self.net.now)
        if progress is not None:
            progress(self.net.now)

    def summary(self, wall_seconds: float = 0.0) -> dict[str, float]:
        """The run's figures (see ``FleetMetrics.summary``)."""
        stats = self.net.stats()
        agv_sent: dict[str, tuple[int, int]] = {}
        for agv_id in self.agvs:
            traffic = stats.per_node.get(agv_id)
            if traffic is None:
                continue
            for kind, (n, b) in traffic.sent.items():
                old = agv_sent.get(kind, (0, 0))
                agv_sent[kind] = (old[0] + n, old[1] + b)
        m = self.metrics_raw
        m.tasks_returned = sum(s.returned for s in self.stations.values())
        return m.summary(
            agvs=len(self.agvs),
            sim_seconds=self.net.now,
            wall_seconds=wall_seconds,
            collisions=self.monitor.collisions,
            lock_overlaps=self.monitor.lock_overlaps,
            messages=stats.messages,
            bytes_=stats.bytes,
            agv_sent=agv_sent,
        )

    # -- FleetSource ------------------------------------------------------------------------

    def layout_view(self) -> Layout:
        """The floor plan."""
        return self.layout

    def vehicles(self) -> Sequence[VehicleState]:
        """Every AGV, by id."""
        out = []
        for agv_id, agv in sorted(self.agvs.items()):
            pose = agv.vehicle.pose()
            locks, request = agv.areas()
            hull = _rings(agv.vehicle.hull())
            out.append(
                VehicleState(
                    agv_id,
                    pose.x,
                    pose.y,
                    pose.heading_rad,
                    self.spec.length_m,
                    self.spec.width_m,
                    agv.display_status(),
                    agv.task.id
                    if agv.task
                    else (agv.pending_task.id if agv.pending_task else None),
                    hull[0] if hull else (),
                    agv.current_hull_length(),
                    tuple(r for a in locks for r in _rings(a)),
                    tuple(_rings(request)),
                )
            )
        return out

    def nodes(self) -> Mapping[str, RoleActivator]:
        """Every live node: AGVs, stations and the observer."""
        return self.net.nodes

    @property
    def observer_id(self) -> str:
        """The dashboard's observer node (no position)."""
        return OBSERVER_ID

    def initiator_roles(self) -> Mapping[str, Callable[[Mapping[str, Any]], Initiator]]:
        """None: locks and awards belong to the fleet's own components, not to HTTP users."""
        return {}

    def metrics(self) -> Mapping[str, float]:
        """Figures so far."""
        return self.summary()

    def pause(self) -> None:
        """Stop simulated time."""
        self._paused = True

    def resume(self) -> None:
        """Let simulated time run."""
        self._paused = False

    def set_speed(self, factor: float) -> None:
        """Simulated seconds per wall second.

        Raises:
            ValueError: ``factor`` is not positive.
        """
        if not (isinstance(factor, int | float) and factor > 0 and math.isfinite(factor)):
            raise ValueError(f"speed must be a positive number, got {factor!r}")
        self._speed = float(factor)

    @property
    def paused(self) -> bool:
        """True between ``pause()`` and ``resume()``."""
        return self._paused

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


def parking_capacity(layout: Layout) -> int:
    """How many AGVs ``layout`` can hold: its distinct parking and charging points.

    An idle AGV rests on one of these, off the lanes. A fleet larger than this has to
    rest on lanes, and on a layout of one-way loops (openTCS Demo-01 has five parking
    spots) the resting AGVs block the loop until it gridlocks.
    """
    usable = set(layout.usable_stations())
    return len(
        {
            station.point
            for kind in ("parking", "charging")
            for station in layout.stations_of_kind(kind)
            if station.id in usable
        }
    )


def demo_source(
    args: argparse.Namespace | None = None,
    *,
    agvs: int | None = None,
    seed: int | None = None,
    processes: int = 0,
) -> Fleet | MeshFleet:
    """The fleet ``objectplaces demo`` shows: the demo warehouse, tasks arriving for ever.

    Accepts the parsed ``demo`` arguments or the keywords ``agvs``, ``seed`` and
    ``processes``: 0 simulates ``agvs`` AGVs on one network in this process; more runs
    that many AGV processes on the WebSocket mesh (a :class:`~agv_app.fleet.mesh.MeshFleet`,
    which the caller must ``await start()`` and ``await stop()``).

    Raises:
        ValueError: ``processes`` is negative or more than the layout can park.
    """
    if args is not None:
        agvs = getattr(args, "agvs", agvs)
        seed = getattr(args, "seed", seed)
        processes = getattr(args, "processes", processes) or 0
    if processes < 0:
        raise ValueError(f"processes must be 0 or more, got {processes!r}")
    if processes:
        from agv_app.fleet.mesh import MeshFleet  # spawns processes: only when asked for

        return MeshFleet(
            agvs=processes,
            seed=1 if seed is None else seed,
            task_interval=MESH_DEMO_TASK_INTERVAL_S / processes,
        )
    return Fleet(demo_warehouse(), FleetConfig(agvs=agvs or 12, seed=1 if seed is None else seed))
