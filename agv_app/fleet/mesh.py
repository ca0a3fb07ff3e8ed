"""A fleet of AGV processes on the WebSocket mesh, seen through an observer node.

:class:`MeshFleet` implements the dashboard's ``FleetSource`` protocol (structurally,
like :class:`~agv_app.fleet.Fleet`) for ``objectplaces demo --processes N``. In the
dashboard's process it runs an observer node (no position, hears every node) and one
node per pick station (fixed nodes running the task-assignment initiator, as in the
simulated fleet), and it spawns every AGV as its own process
(:mod:`agv_app.fleet.agv_process`, run by :mod:`agv_app.fleet.processes`), all on
127.0.0.1, every link mutual TLS (:mod:`agv_app.fleet.mesh_nodes`).

What the fleet reports of the AGVs is what the observer hears: tasks created here and
seen done (in a :class:`~agv_app.tasks.book.TaskBook` as the simulated fleet's), traffic
on the links of the nodes here, and a best-effort safety check over the observed shapes
(views lag the vehicles by the publication interval, so only overlaps that last count).

Its parts, in agv_app.fleet: mesh_options, mesh_nodes (the nodes here), mesh_run,
mesh_watch and mesh_views (the AGVs as heard), mesh_tasks, mesh_figures, mesh_charging.
``await fleet.start()`` before use and ``await fleet.stop()`` after (the dashboard's
app does both in its lifespan); ``stop`` terminates and reaps every child process.
"""

from __future__ import annotations

import asyncio
import random
import sys
import time
from collections.abc import Collection, Mapping, Sequence

from agv_app.fleet.agv_args import POLL_INTERVAL_S
from agv_app.fleet.base import FleetSourceBase
from agv_app.fleet.liveness import REPUBLISH_BEATS, REST_BEAT_S
from agv_app.fleet.mesh_figures import link_traffic
from agv_app.fleet.mesh_nodes import LocalNodes, vda5050_monitor
from agv_app.fleet.mesh_options import POSES_PER_SECOND, AgvLaunch, Joining, pose_interval_for
from agv_app.fleet.mesh_orders import OperatorOrders
from agv_app.fleet.mesh_run import MeshRun
from agv_app.fleet.mesh_tasks import AutoTasks
from agv_app.fleet.mesh_watch import ObservedAgvs
from agv_app.fleet.metrics import FleetMetrics
from agv_app.fleet.parking import ParkingPlan
from agv_app.fleet.processes import AgvProcesses
from agv_app.fleet.remote import RemoteNode
from agv_app.fleet.view import VehicleState
from agv_app.geometry import XY
from agv_app.layout.choice import layout_digest
from agv_app.layout.demo import DEMO_VEHICLE_LENGTH_M, DEMO_VEHICLE_WIDTH_M, demo_warehouse
from agv_app.layout.graph import Layout
from agv_app.tasks.admission import CROWDED, limit_for
from agv_app.tasks.desk import TaskDesk, require_task_stations
from agv_app.tasks.free_flow import FreeFlowBound, FreeFlowTimer
from agv_app.tasks.journal import TaskJournal
from agv_app.tasks.load import TaskArrivals
from agv_app.vda5050.link import VdaCredentials
from agv_app.vehicle.battery import BatterySpec
from agv_app.vehicle.kinematics import VehicleSpec
from objectplaces import RoleActivator
from objectplaces.mesh import MeshNode

__all__ = ["POSES_PER_SECOND", "Joining", "MeshFleet", "pose_interval_for"]


class MeshFleet(FleetSourceBase):
    """A ``FleetSource`` over the WebSocket mesh: AGV processes, a base, an observer.

    ``pause()`` stops the fleet: no new automatic tasks, and every AGV process brakes
    to a standstill and stands, locks kept (:mod:`agv_app.fleet.holding`); ``resume()``
    lets them drive on. ``vehicles()`` shows what they report, never what was asked.
    The operator's orders (the stop, ``blocks``, ``charging``) are the observer's properties.

    Args:
        agvs: number of AGV processes.
        seed: seeds the task generator and the processes.
        layout: must be the demo warehouse (the processes build it themselves); default.
        task_interval: mean seconds between automatic tasks, the first one as soon as
            every AGV is seen (None: no automatic tasks).
        start_tasks: tasks created at once when every AGV is first seen (with automatic
            tasks only), so the fleet is at its load from the start.
        t_update, run_seconds, dwell, transport, zenoh_mode, republish_beats, rest_beat,
        poll_interval, batteries: how the AGV processes run and link, as the fields of these names
            of :class:`~agv_app.fleet.mesh_options.AgvLaunch` (the seed too).
        publish_interval: seconds between two pose reports of a moving AGV to the
            observer (None: by the fleet's size, :func:`pose_interval_for`).
        station_range: first auction range of the stations.
        stop_timeout: how long ``stop`` waits for the processes after SIGTERM.
        python, capture_output: the interpreter that runs the AGV processes, and whether
            their output goes to files in the run's temp dir (``AgvProcesses``).
        vda5050: ``mqtts://HOST:PORT`` of a broker: every AGV process speaks VDA 5050
            over it (docs/vda5050.md), and ``metrics()`` adds the broker's figures.
        vda5050_credentials: with ``vda5050``, the broker's throwaway fleet PKI, which
            issues every certificate (:func:`~agv_app.fleet.mesh_nodes.vda5050_monitor`).
        joining: join a fleet whose AGVs run elsewhere instead of spawning them
            (``agvs``: how many AGVs to hear before the first automatic task); its
            nodes' certificates come from ``joining.pki``.
        max_open_tasks: tasks on the floor at once, at most; the others wait at the
            task desk (None: no limit; ``"auto"``: a limit that follows the floor's
            long waits; :data:`~agv_app.tasks.admission.CROWDED`, the default:
            ``"auto"`` for a fleet larger than its floor carries, else none, as the
            simulated fleet; :class:`~agv_app.tasks.desk.TaskDesk`).
        store: the durable order book the task desk writes through to and resumes
            from (:class:`~agv_app.tasks.store.OrderStore`; None: none).

    Raises:
        ValueError: ``agvs`` < 1, ``start_tasks`` < 0, more AGVs than parking spots,
            an unknown ``zenoh_mode``, a ``rest_beat`` that is not a positive number, or
            ``max_open_tasks`` neither >= 1 nor "auto".
    """

    def __init__(
        self,
        *,
        agvs: int = 6,
        seed: int = 1,
        layout: Layout | None = None,
        task_interval: float | None = None,
        start_tasks: int = 0,
        t_update: float = 1.0,
        run_seconds: float = 86_400.0,
        station_range: float = 30.0,
        dwell: float = 5.0,
        batteries: bool | BatterySpec = False,
        stop_timeout: float = 5.0,
        python: str = sys.executable,
        capture_output: bool = True,
        vda5050: str | None = None,
        vda5050_credentials: VdaCredentials | None = None,
        transport: str = "websocket",
        zenoh_mode: str = "client",
        publish_interval: float | None = None,
        republish_beats: int = REPUBLISH_BEATS,
        rest_beat: float | None = REST_BEAT_S,
        poll_interval: float = POLL_INTERVAL_S,
        max_open_tasks: int | str | None = CROWDED,
        joining: Joining | None = None,
        store: TaskJournal | None = None,
    ) -> None:
        if agvs < 1:
            raise ValueError(f"agvs must be at least 1, got {agvs!r}")
        if start_tasks < 0:
            raise ValueError(f"start_tasks must be 0 or more, got {start_tasks!r}")
        self.layout = layout or demo_warehouse()
        self.joining = joining
        self.tag = f"layout:{layout_digest(self.layout)}"
        self.agv_count = agvs
        self.seed = seed
        self.task_interval = task_interval
        self.transport = transport
        self.publish_interval = publish_interval or pose_interval_for(agvs)  # > 0 or None
        self.vda5050 = vda5050
        self.launch = AgvLaunch(
            self.tag,
            seed,
            t_update,
            run_seconds,
            dwell,
            transport,
            zenoh_mode,
            self.publish_interval,
            republish_beats,
            rest_beat,
            poll_interval,
            vda5050,
            batteries,
        )
        """How the AGV processes run and link."""
        spec = VehicleSpec(DEMO_VEHICLE_LENGTH_M, DEMO_VEHICLE_WIDTH_M)
        require_task_stations(self.layout)
        self.parking = ParkingPlan(self.layout, spec, agvs, rest_elsewhere=False)
        self.homes = self.parking.homes
        self.free_flow = FreeFlowBound(
            FreeFlowTimer(self.layout, spec.max_speed_m_s, dwell), self.homes
        )
        width = max(2, len(str(agvs)))
        # Joining a fleet, the AGVs are learned as the observer hears them (the roster).
        self.agv_ids = [] if joining else [f"agv-{i + 1:0{width}d}" for i in range(agvs)]
        self.rng = random.Random(seed)
        self.arrivals = None if task_interval is None else TaskArrivals(task_interval, self.rng)
        self.metrics_raw = FleetMetrics()
        self._started_at: float | None = None  # before the desk, which reads the clock
        super().__init__(
            self.layout,
            TaskDesk(
                self.layout,
                rng=self.rng,
                clock=lambda: self.now,
                station_range=station_range,
                tally=self.metrics_raw.tally,
                on_created=self.free_flow.add,
                max_open=limit_for(max_open_tasks, self.layout, agvs),
                store=store,
            ),
        )
        self.processes = AgvProcesses(python=python, capture_output=capture_output)
        shared_pki, self.broker_monitor = vda5050_monitor(vda5050, vda5050_credentials)
        self.seen = ObservedAgvs(
            self.agv_ids,
            self.desk,
            self.processes,
            observer=lambda: self.own_nodes.observer,
            clock=lambda: self.now,
            running=lambda: self.started,
            clock_offset=lambda: self._started_at or 0.0,
            min_overlap_s=2 * t_update,
        )
        """The AGVs as the observer hears them: views, failures, safety and stalls."""
        self.monitor, self.stalls = self.seen.monitor, self.seen.stalls
        self.orders = OperatorOrders(
            self.layout, self.holds, lambda n, v: self.own_nodes.publish(n, v), self.seen
        )
        """What the operator told the AGV processes (the observer's properties)."""
        self.charging = self.orders.charge(self.launch.battery_spec, self.parking, self.agv_ids)
        self.blocks = self.orders.blocks
        self.own_nodes: LocalNodes = LocalNodes(shared_pki, self.seen, self.orders)
        self.lifecycle = MeshRun(
            self.own_nodes,
            self.processes,
            self.desk,
            self.launch,
            agv_ids=self.agv_ids,
            homes=self.homes,
            joining=joining,
            check=self.check,
            broker_monitor=self.broker_monitor,
            stop_timeout=stop_timeout,
        )
        self.auto_tasks = AutoTasks(
            self.desk, self.arrivals, start_tasks=start_tasks, agvs=agvs, heard=self.seen.heard
        )

    @property
    def started(self) -> bool:
        """Whether ``start`` ran (and ``stop`` has not)."""
        return self._started_at is not None and not self.lifecycle.stopped

    def pids(self) -> list[int]:
        """Process ids of the AGV processes spawned (running or not)."""
        return self.processes.pids()

    def exit_codes(self) -> dict[str, int | None]:
        """Each AGV process's exit status, by AGV id (None: still running)."""
        return self.processes.exit_codes()

    async def start(self) -> None:
        """Start the observer and the transport base and spawn the AGV processes.

        Returns once the processes are spawned; :meth:`wait_ready` waits until the
        observer hears every AGV.

        Raises:
            RuntimeError: called twice.
            OSError: a node cannot listen or a process cannot be spawned (whatever was
                started is stopped again).
        """
        if self._started_at is not None:
            raise RuntimeError("MeshFleet.start() called twice")
        loop = asyncio.get_running_loop()
        self._started_at = time.monotonic()
        try:
            await self.lifecycle.start(loop)
        except BaseException:
            await self.stop()
            raise

    @property
    def observer(self) -> MeshNode | None:
        """The observer node (None before ``start``)."""
        return self.own_nodes.observer

    async def wait_ready(self) -> None:
        """Wait until the observer has heard every AGV's position and has its display
        (bound it with ``asyncio.timeout``; :meth:`missing` names who is still missing).

        Raises:
            RuntimeError: an AGV process has exited.
        """
        await self.seen.wait_ready()

    def missing(self) -> list[str]:
        """Ids of the AGVs not heard yet, or whose display has not come yet."""
        return self.seen.missing()

    def child_logs(self) -> dict[str, str]:
        """The captured output of every AGV process so far (for diagnostics)."""
        return self.processes.logs()

    async def stop(self) -> None:
        """Stop everything: terminate and reap every AGV process, close the nodes.

        The children get end of file on stdin and SIGTERM, and ``stop_timeout``
        seconds to leave the mesh; whoever is left then is killed. Idempotent.
        """
        await self.lifecycle.stop()

    @property
    def final_logs(self) -> dict[str, str]:
        """Every AGV process's output once ``stop`` has reaped them (``MeshRun``)."""
        return self.lifecycle.final_logs

    def check(self) -> None:
        """Check the observed hulls and locks, track stalls, charge (``ObservedAgvs.check``)."""
        self.seen.check(self.now, self.charging)

    def create_task(self, station_id: str, drop: str | None = None) -> str:
        """Create a transport task at a pick station; its station auctions it.

        Raises:
            KeyError: no station has that id.
            ValueError: the station does not hand out loads, or the fleet is not running.
        """
        if station_id not in self.layout.stations:
            raise KeyError(f"unknown station {station_id!r}")
        if not self.started:
            raise ValueError("the mesh fleet is not running (start() it first)")
        return self.desk.create(station_id, drop)

    def assignment(self, task_id: str) -> str | None:
        """The AGV a task was awarded to (None: not yet, or unknown)."""
        record = self.desk.book.get(task_id)
        return None if record is None else record.vehicle

    def vehicles(self) -> Sequence[VehicleState]:
        """Every AGV the observer hears, by id, as it last heard it; a failed one (its
        process exited, or its node departed) where it was last heard, ``failed``."""
        return self.seen.vehicles()

    def vehicle_ids(self) -> Collection[str]:
        """The AGVs spawned, or, joining a fleet, every AGV heard so far."""
        return self.seen.vehicle_ids()

    def _apply_holds(self) -> None:
        self.orders.publish_holds()

    def _send_home(self, vehicle_id: str) -> None:
        self.orders.send_home(vehicle_id)  # ValueError: failed, or loaded

    def pause(self) -> None:
        """Stop the fleet: no new automatic tasks, and every vehicle holds."""
        super().pause()
        self.stop_vehicles()

    def resume(self) -> None:
        """Resume the fleet (vehicles stopped on their own stay stopped)."""
        super().resume()
        self.resume_vehicles()

    def vehicle_route(self, vehicle_id: str) -> tuple[XY, ...]:
        """The rest of an AGV's route as it last published it, from where it stands;
        ``()`` at rest or failed.

        Raises:
            KeyError: no AGV has that id.
        """
        return self.seen.route(vehicle_id)

    def nodes(self) -> Mapping[str, RoleActivator | RemoteNode]:
        """The observer and the transport base, and a read-only stand-in for every live
        AGV the observer hears (its node runs in its process; ``agv_app.fleet.remote``)."""
        out: dict[str, RoleActivator | RemoteNode] = {n.node_id: n for n in self.own_nodes.live()}
        out.update(self.seen.remote_nodes())
        return out

    def metrics(self) -> Mapping[str, float]:
        """Observed figures: tasks, traffic of this process's links, safety, stalls."""
        return self.seen.figures(
            link_traffic(self.own_nodes.live(), self.transport),
            joining=self.joining is not None,
            agvs=self.agv_count,
            free_flow=self.free_flow,
            broker_monitor=self.broker_monitor,
            now=self.now,
        )

    def set_speed(self, factor: float) -> None:
        """Only real time is possible: the AGVs are processes with their own clocks.

        Raises:
            ValueError: ``factor`` is not 1.0.
        """
        if factor != 1.0:
            raise ValueError(f"AGV processes run in real time: speed is always 1.0, got {factor!r}")

    @property
    def speed(self) -> float:
        """Always 1.0."""
        return 1.0

    @property
    def now(self) -> float:
        """Wall-clock seconds since ``start`` (monotonic clock: handlers may run in threads)."""
        if self._started_at is None:
            return 0.0
        return max(0.0, time.monotonic() - self._started_at)

    def advance(self, seconds: float) -> None:
        """Bookkeeping only (the processes run themselves): issue automatic tasks."""
        if seconds <= 0 or not self.started:
            return
        if self.arrivals is None or not self.automatic_tasks or not self.stations:
            return
        self.auto_tasks.tick(self.now)
