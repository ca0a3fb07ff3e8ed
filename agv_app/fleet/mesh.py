"""A fleet of AGV processes on the WebSocket mesh, seen through an observer node.

:class:`MeshFleet` implements the dashboard's ``FleetSource`` protocol (structurally,
like :class:`~agv_app.fleet.Fleet`) for ``objectplaces demo --processes N``. In the
dashboard's process it runs an observer node (no position, hears every node) and one
node per pick station (fixed nodes running the task-assignment initiator, as in the
simulated fleet), and it spawns every AGV as its own process
(:mod:`agv_app.fleet.agv_process`, run by :mod:`agv_app.fleet.processes`), all on
127.0.0.1. Every link is mutual TLS: the run makes a throwaway fleet CA in a private
temporary folder (:class:`~objectplaces.security.TemporaryPki`), issues a certificate
to each node, hands the children the folder (``--pki``), and removes it on ``stop``.

Everything the fleet reports about the AGVs comes from what the observer hears: the
properties each AGV publishes (position, heading, hull length, state, task, and its
locked and requested projections). So the figures are *observed* ones: tasks created
here and seen done (in the same :class:`~agv_app.tasks.book.TaskBook` as the simulated
fleet's), traffic on the links of the nodes in this process, and a safety
check over the observed shapes, which is best effort (views lag the vehicles by the
publication interval, so only overlaps that last count).

``await fleet.start()`` before use and ``await fleet.stop()`` after (the dashboard's
app does both in its lifespan); ``stop`` terminates and reaps every child process.
"""

from __future__ import annotations

import asyncio
import contextlib
import math
import random
import sys
import time
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from agv_app.fleet.agv_process import POLL_INTERVAL_S, process_liveness
from agv_app.fleet.base import FleetSourceBase
from agv_app.fleet.blocks import FloorBlocks
from agv_app.fleet.closed_listener import CLOSED_PROPERTY, closed_wire
from agv_app.fleet.display_feed import DISPLAY_ROLE, DisplayCollector, display_group
from agv_app.fleet.holding import HOLD_PROPERTY
from agv_app.fleet.liveness import REPUBLISH_BEATS, REST_BEAT_S, liveness_arguments
from agv_app.fleet.metrics import FleetMetrics
from agv_app.fleet.observed import LastingOverlaps
from agv_app.fleet.parking import ParkingPlan
from agv_app.fleet.processes import AgvProcesses
from agv_app.fleet.remote import RemoteNode
from agv_app.fleet.roster import AgvRoster
from agv_app.fleet.sending_home import SEND_HOME_PROPERTY, SENT_HOME_PROPERTY, SendHomeOrders
from agv_app.fleet.stalls import StallWatch
from agv_app.fleet.view import OBSERVER_ID, VehicleState
from agv_app.geometry import XY
from agv_app.layout.choice import layout_digest
from agv_app.layout.demo import DEMO_VEHICLE_LENGTH_M, DEMO_VEHICLE_WIDTH_M, demo_warehouse
from agv_app.layout.graph import Layout
from agv_app.protocol import AGV_KIND, OBSERVER_KIND
from agv_app.tasks.admission import CROWDED, limit_for
from agv_app.tasks.desk import BASE_ID, TaskDesk, require_task_stations
from agv_app.tasks.free_flow import FreeFlowBound, FreeFlowTimer
from agv_app.tasks.journal import TaskJournal
from agv_app.tasks.load import TaskArrivals
from agv_app.traffic.monitor import SafetyMonitor
from agv_app.vda5050.link import VdaCredentials
from agv_app.vda5050.monitor import MONITOR_ID, MONITOR_ROLES, BrokerMonitor
from agv_app.vehicle.kinematics import VehicleSpec
from objectplaces import RoleActivator
from objectplaces.mesh import MeshNode, start_node
from objectplaces.security import Identity, TemporaryPki
from objectplaces.zenoh_router import ZenohRouter, start_router

__all__ = ["POSES_PER_SECOND", "Joining", "MeshFleet", "pose_interval_for"]

_HOST = "127.0.0.1"
_CHECK_INTERVAL_S = 0.25


POSES_PER_SECOND = 100.0
"""About how many poses a whole fleet of AGV processes reports a second when moving."""


def pose_interval_for(agvs: int) -> float:
    """Seconds between two pose reports of an AGV in a fleet of ``agvs``: 0.2 s up to 20
    AGVs, then longer, so that the fleet's poses stay about ``POSES_PER_SECOND``.

    Every pose goes to the observer, in the dashboard's process, over the display
    session (:mod:`agv_app.fleet.display_feed`): the observer alone draws from them.
    Safety does not wait for them (an AGV publishes its position and hull length with
    every request and release).
    """
    return max(0.2, agvs / POSES_PER_SECOND)


def _is_agv(props: Mapping[str, Any]) -> bool:
    """Whether properties the observer holds are an AGV's, with a position to draw."""
    return props.get("kind") == AGV_KIND and isinstance(props.get("position"), tuple)


@dataclass(frozen=True)
class Joining:
    """How a control process joins a fleet whose vehicles run elsewhere
    (``objectplaces control``): it spawns nothing, and learns the AGVs as it hears them.

    Attributes:
        connect: where the fleet is: nodes to join (the mesh) or routers (Zenoh).
        listen: where the observer listens (the mesh: AGVs may join through it).
        pki: the fleet PKI folder with the certificates of ``observer`` and ``base``.
        layout_argument: the ``--layout`` the fleet runs (for the record and messages).
    """

    connect: tuple[str, ...]
    listen: str = f"{_HOST}:0"
    pki: Path | None = None
    layout_argument: str | None = None


class MeshFleet(FleetSourceBase):
    """A ``FleetSource`` over the WebSocket mesh: AGV processes, a transport base, an
    observer.

    Real-time processes cannot be paused, so ``pause()`` stops the fleet: it stops
    issuing new automatic tasks and holds every vehicle (``stop_vehicles``: the
    observer publishes the stop, each AGV process brakes to a standstill and stands,
    locks kept, :mod:`agv_app.fleet.holding`); ``resume()`` lets them drive on. The
    vehicles report whether they hold and their speed, and ``vehicles()`` shows that,
    never what was asked. The speed is always 1.0.

    Args:
        agvs: number of AGV processes.
        seed: seeds the task generator and the processes.
        layout: must be the demo warehouse (the processes build it themselves); default.
        task_interval: mean seconds between automatic tasks, the first one as soon as
            every AGV is seen (None: no automatic tasks).
        start_tasks: tasks created at once when every AGV is first seen (with automatic
            tasks only), so the fleet is at its load from the start.
        t_update: property update interval of every node (the safe time is twice it).
        run_seconds: every AGV process stops by itself after this long.
        station_range: first auction range of the stations.
        dwell: seconds an AGV spends at a station.
        batteries: every AGV process drains a battery and reports its state of charge
            (``battery``, VDA 5050 ``powerSupply``); there is no charging
            (:mod:`agv_app.vehicle.battery_drain`).
        stop_timeout: how long ``stop`` waits for the processes after SIGTERM before
            it kills them.
        python: the interpreter that runs the AGV processes.
        capture_output: keep the children's stdout and stderr off this process's
            terminal (they go to files in the run's temp dir).
        vda5050: ``mqtts://HOST:PORT`` of a broker: every AGV process speaks VDA 5050
            over it (docs/vda5050.md), and ``metrics()`` adds the broker's figures.
        vda5050_credentials: with ``vda5050``, the broker's fleet PKI, a throwaway one
            (:class:`~objectplaces.security.TemporaryPki`): the run issues every
            certificate from it (the mesh's too, one CA), and the broker monitor
            connects as ``vda5050-monitor``.
        transport: ``websocket`` (the mesh) or ``zenoh``.
        joining: join a fleet whose AGVs run elsewhere instead of spawning them
            (``agvs``: how many AGVs to hear before the first automatic task); its
            nodes' certificates come from ``joining.pki``.
        zenoh_mode: on Zenoh, ``client`` (default: a router in this process, every node
            its client) or ``peer`` (every node a peer, found through the observer).
        publish_interval: seconds between two pose reports of a moving AGV to the
            observer (None: by the fleet's size, :func:`pose_interval_for`); the
            sessions, roles and traffic each AGV shows the dashboard go out at most five
            times as seldom.
        republish_beats: liveness beats between two republications of every property,
            by every node (0: no beats, everything republished each ``t_update``).
        rest_beat: an AGV parked at its home with no task, the transport base and the
            observer beat only this often, and every node waits that much longer for
            them (None: no rest; with beats only; docs/protocol.md §2, "A node at rest").
        poll_interval: on Zenoh, the AGV processes hand received frames on every this
            many seconds (0: each at once; ``agv_app.fleet.agv_process``).
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
        batteries: bool = False,
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
        self.start_tasks = start_tasks
        self.t_update = t_update
        self.run_seconds = run_seconds
        self.station_range = station_range
        self.dwell = dwell
        self.batteries = batteries
        self.stop_timeout = stop_timeout
        self.transport = transport
        if zenoh_mode not in ("client", "peer"):
            raise ValueError(f"zenoh_mode must be 'client' or 'peer', got {zenoh_mode!r}")
        self.zenoh_mode = zenoh_mode
        self.publish_interval = (
            pose_interval_for(agvs) if publish_interval is None else publish_interval
        )
        if rest_beat is not None and not (rest_beat > 0 and math.isfinite(rest_beat)):
            raise ValueError(f"rest_beat must be a positive number, got {rest_beat!r}")
        self.republish_beats = republish_beats
        self.rest_beat = rest_beat
        self.poll_interval = poll_interval
        self._router: ZenohRouter | None = None
        self._pki: TemporaryPki | None = None
        self.final_logs: dict[str, str] = {}
        """Every AGV process's output once ``stop`` has reaped them (its last line,
        ``closed``, tells how late its control steps ran)."""
        self.python = python
        self.capture_output = capture_output
        spec = VehicleSpec(DEMO_VEHICLE_LENGTH_M, DEMO_VEHICLE_WIDTH_M)
        require_task_stations(self.layout)
        self.homes = ParkingPlan(self.layout, spec, agvs, rest_elsewhere=False).homes
        self.free_flow = FreeFlowBound(
            FreeFlowTimer(self.layout, spec.max_speed_m_s, dwell), self.homes
        )
        width = max(2, len(str(agvs)))
        # Joining a fleet, the AGVs are learned as the observer hears them (the roster).
        self.agv_ids = [] if joining else [f"agv-{i + 1:0{width}d}" for i in range(agvs)]
        self.rng = random.Random(seed)
        self.arrivals = None if task_interval is None else TaskArrivals(task_interval, self.rng)
        self.metrics_raw = FleetMetrics()
        self.monitor = SafetyMonitor()
        self.overlaps = LastingOverlaps(self.monitor, min_s=2 * t_update)
        # The desk is made below; the watch tells it of long waits once the fleet runs.
        self.stalls = StallWatch(on_long_wait=lambda _agv, now: self.desk.long_wait(now))
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
        self.homeward = SendHomeOrders()
        """Requests to go home the AGV processes have not answered yet."""
        self.processes = AgvProcesses(python=python, capture_output=capture_output)
        self.vda5050 = vda5050
        self.broker_monitor: BrokerMonitor | None = None
        self._shared_pki: TemporaryPki | None = None
        if vda5050 is not None:
            if vda5050_credentials is None or not isinstance(vda5050_credentials.pki, TemporaryPki):
                raise ValueError(
                    "vda5050 needs vda5050_credentials with the broker's throwaway PKI "
                    "(the AGV processes hold one certificate for the mesh and the broker)"
                )
            self._shared_pki = vda5050_credentials.pki
            self.broker_monitor = BrokerMonitor(
                vda5050_credentials.link(vda5050, MONITOR_ID, roles=MONITOR_ROLES)
            )
        self._monitor_task: asyncio.Task[None] | None = None
        self.observer: MeshNode | None = None
        self.blocks = FloorBlocks(self.layout, on_change=lambda _: self._publish_closed())
        """The parts of the floor the operator closed, published to every AGV process."""
        self.display = DisplayCollector(on_report=self._on_report)
        """What each AGV process shows, reported to the observer (its display session)."""
        self._base: MeshNode | None = None
        self._watcher: asyncio.Task[None] | None = None
        self._stopped = False
        self._advanced = 0.0
        self._next_task_at: float | None = None
        self.roster = AgvRoster(
            self.agv_ids,
            self._agv_views,
            self._agv_view,
            clock_offset=lambda: self._started_at or 0.0,
        )

    # -- life cycle -------------------------------------------------------------------

    @property
    def started(self) -> bool:
        """Whether ``start`` ran (and ``stop`` has not)."""
        return self._started_at is not None and not self._stopped

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
            await self._start(loop)
        except BaseException:
            await self.stop()
            raise

    async def _start(self, loop: asyncio.AbstractEventLoop) -> None:
        liveness = process_liveness(self.t_update, self.republish_beats, self.rest_beat)
        node_args: dict[str, Any] = {**liveness_arguments(liveness), "tag": self.tag}
        zenoh = self.transport == "zenoh"
        if zenoh:
            node_args["poll_interval"] = self.poll_interval or None
        if self.joining is not None:
            await self._join(self.joining, node_args, zenoh)
            self._watcher = loop.create_task(self._watch(), name="mesh-fleet-watch")
            return
        self.processes.open_run_dir()
        self._pki = pki = self._shared_pki or TemporaryPki(fleet="demo")
        for agv_id in self.agv_ids:
            pki.identity(agv_id, role="agv")
        link: dict[str, Any]
        if zenoh and self.zenoh_mode == "client":
            # One router and every node its client: a link per node, where peers would
            # open one per pair (1,225 at 50 AGVs): Zenoh peers do not relay for each other.
            self._router = await start_router(
                tls=pki.identity("router", role="router", addresses=(_HOST,)),
                listen=[f"tls/{_HOST}:0"],
            )
            endpoints = self._router.endpoints
            node_args.update(transport="zenoh", mode="client", connect=endpoints)
            link = {}
            link_args = ["--transport", "zenoh", "--mode", "client"]
            link_args += [a for e in endpoints for a in ("--connect", e)]
        elif zenoh:  # every node a peer; the others find each other through the observer
            node_args.update(transport="zenoh", listen=[f"tls/{_HOST}:0"])
        else:
            node_args["listen"] = f"{_HOST}:0"
        observer = await self._start_observer(pki.identity(OBSERVER_ID, role="control"), node_args)
        if not (zenoh and self.zenoh_mode == "client"):
            link = {"connect": [observer.address]} if zenoh else {"join": [observer.address]}
            link_args = ["--transport", "zenoh", "--connect"] if zenoh else ["--join"]
            link_args.append(observer.address)
        if zenoh:
            link_args += ["--poll-interval", str(self.poll_interval)]
        link_args += ["--republish-beats", str(self.republish_beats)]
        link_args += ["--rest-beat", "none" if self.rest_beat is None else str(self.rest_beat)]
        self._base = await start_node(
            BASE_ID, tls=pki.identity(BASE_ID, role="control"), **link, **node_args
        )
        self.desk.open_base(self._base)
        peers = self.agv_count + 1  # the observer, the base and the other AGVs
        for i, (agv_id, home) in enumerate(zip(self.agv_ids, self.homes, strict=True)):
            self.processes.spawn(
                agv_id,
                [
                    "--listen", f"{_HOST}:0",
                    *link_args,
                    "--pki", str(pki.directory),
                    "--home", home,
                    "--seed", str(self.seed * 1000 + i),
                    "--run-seconds", str(self.run_seconds),
                    "--t-update", str(self.t_update),
                    "--publish-interval", str(self.publish_interval),
                    "--introspection-interval", str(5 * self.publish_interval),
                    "--dwell", str(self.dwell),
                    *(["--battery"] if self.batteries else []),
                    "--expect-peers", str(peers),
                    *([] if self.vda5050 is None else ["--vda5050", self.vda5050]),
                ],
            )  # fmt: skip
        self._watcher = loop.create_task(self._watch(), name="mesh-fleet-watch")
        if self.broker_monitor is not None:
            self._monitor_task = loop.create_task(self.broker_monitor.run(), name="vda5050-monitor")

    async def _start_observer(self, tls: Identity, node_args: dict[str, Any]) -> MeshNode:
        observer: MeshNode = await start_node(OBSERVER_ID, tls=tls, **node_args)
        observer.update_node_property("kind", OBSERVER_KIND)
        observer.set_at_rest(True)  # it listens, and says nothing more
        observer.update_node_property(HOLD_PROPERTY, self.holds.wire())  # the operator's stop
        self.observer = observer
        observer.update_node_property(SEND_HOME_PROPERTY, self.homeward.wire())
        self._publish_closed()
        observer.register_node_property_observer(
            self._on_property, names=("last_done", SENT_HOME_PROPERTY)
        )
        observer.start_interaction(self.display, display_group(), DISPLAY_ROLE)
        observer.register_node_departure_observer(lambda node_id, _: self._departed(node_id))
        return observer

    async def _join(self, joining: Joining, node_args: dict[str, Any], zenoh: bool) -> None:
        """Start the observer and the base as members of a fleet that runs elsewhere."""
        if joining.pki is None:
            raise ValueError("joining a fleet needs the fleet PKI folder (pki=...)")
        observer_id = Identity.from_pki(joining.pki, OBSERVER_ID)
        base_id = Identity.from_pki(joining.pki, BASE_ID)
        if zenoh:
            node_args.update(transport="zenoh", mode="client", connect=list(joining.connect))
            base_link: dict[str, Any] = {}
        else:
            base_link = {"join": [*joining.connect]}
        observer = await self._start_observer(
            observer_id,
            {
                **node_args,
                **({} if zenoh else {"listen": joining.listen, "join": [*joining.connect]}),
            },
        )
        if not zenoh:
            base_link["join"].append(observer.address)
        self._base = await start_node(BASE_ID, tls=base_id, **base_link, **node_args)
        self.desk.open_base(self._base)

    async def wait_ready(self) -> None:
        """Wait until the observer has heard every AGV's position and has its display
        (bound it with ``asyncio.timeout``; :meth:`missing` names who is still missing).

        Raises:
            RuntimeError: an AGV process has exited.
        """
        while self.missing():
            dead = self.processes.exited()
            if dead:
                raise RuntimeError(f"AGV processes exited: {', '.join(dead)}")
            await asyncio.sleep(0.1)

    def missing(self) -> list[str]:
        """Ids of the AGVs the observer has not heard yet, or whose display (what draws
        them: heading, locks ...) has not come yet."""
        seen, shown = self._agv_ids_heard(), self.display.reports
        return [a for a in self.agv_ids if a not in seen or a not in shown]

    def child_logs(self) -> dict[str, str]:
        """The captured output of every AGV process so far (for diagnostics)."""
        return self.processes.logs()

    async def stop(self) -> None:
        """Stop everything: terminate and reap every AGV process, close the nodes.

        The children get end of file on stdin and SIGTERM, and ``stop_timeout``
        seconds to leave the mesh; whoever is left then is killed. Idempotent.
        """
        if self._stopped:
            return
        self._stopped = True
        for task in (self._watcher, self._monitor_task):
            if task is not None:
                task.cancel()
                with contextlib.suppress(asyncio.CancelledError):
                    await task
        self._watcher = self._monitor_task = None
        await self.processes.reap(self.stop_timeout)
        for node in (self._base, self.observer):
            if node is not None:
                await node.close()
        if self._router is not None:
            await self._router.close()
            self._router = None
        self.final_logs = self.processes.logs()
        self.processes.close()
        if self._pki is not None and self._pki is not self._shared_pki:
            self._pki.remove()
        self._pki = None

    # -- observing --------------------------------------------------------------------

    def _on_property(self, node_id: str, name: str, value: Any) -> None:
        if name == "last_done" and isinstance(value, str):
            self.desk.finish(value, now=self.now)
        elif name == SENT_HOME_PROPERTY and self.homeward.answered(node_id, value):
            self._publish(SEND_HOME_PROPERTY, self.homeward.wire())

    def _on_report(self, node_id: str, report: Mapping[str, Any]) -> None:
        if report.get("state") == "driving":
            task = self.display.reports.get(node_id, {}).get("task")
            if isinstance(task, str):
                self.desk.book.start(task, node_id, now=self.now)

    def _departed(self, node_id: str) -> None:
        if self.started:
            self.roster.departed(node_id)

    def _agv_ids_heard(self) -> set[str]:
        """Ids of the AGVs the observer hears (no display merged: a count, a check)."""
        if self.observer is None or self.observer.closed:
            return set()
        return {n for n, props in self.observer.view().items() if _is_agv(props)}

    def _agv_views(self) -> list[tuple[str, Mapping[str, Any]]]:
        """Every AGV the observer hears, by id, its display over its properties."""
        if self.observer is None or self.observer.closed:
            return []
        view, shown = self.observer.view(), self.display.shown
        return [(n, shown(n, view[n])) for n in sorted(view) if _is_agv(view[n])]

    def _agv_view(self, agv_id: str) -> Mapping[str, Any] | None:
        """One AGV as ``_agv_views`` gives it, without merging the others (None: not heard)."""
        if self.observer is None or self.observer.closed:
            return None
        props = self.observer.view().get(agv_id)
        if props is None or not _is_agv(props):
            return None
        return self.display.shown(agv_id, props)

    async def _watch(self) -> None:
        """Check the observed shapes and stalls a few times a second, until cancelled."""
        while True:
            await asyncio.sleep(_CHECK_INTERVAL_S)
            self.check()

    def check(self) -> None:
        """Run the safety monitor over the observed hulls and locks; track stalls.

        An overlap counts once it has lasted ``2 * t_update``: the observer hears each
        AGV at a different moment, so a short overlap of two views may be two moments.
        """
        now = self.now
        vehicles = self.vehicles()
        self.overlaps.check(now, vehicles, self.roster.observed())
        for v in vehicles:
            self.stalls.observe(v.id, stalled=v.status == "waiting", now=now)

    # -- tasks ----------------------------------------------------------------------------

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

    # -- FleetSource ----------------------------------------------------------------------

    def _note_exits(self) -> None:
        if self.started:
            self.roster.exited(self.processes.exit_codes())

    def vehicles(self) -> Sequence[VehicleState]:
        """Every AGV the observer hears, by id, as it last heard it; a failed one (its
        process exited, or its node departed) where it was last heard, ``failed``."""
        self._note_exits()
        return self.roster.vehicles()

    def vehicle_ids(self) -> Collection[str]:
        """The AGVs spawned, or, joining a fleet, every AGV heard so far."""
        self._note_exits()
        return [*self.roster.agv_ids]

    def _apply_holds(self) -> None:
        """Publish the stop as the observer's property; every AGV process follows it."""
        self._publish(HOLD_PROPERTY, self.holds.wire())

    def _send_home(self, vehicle_id: str) -> None:
        """Ask the AGV process over the observer's property (it acts as it hears it:
        :mod:`agv_app.fleet.sending_home`).

        Raises:
            ValueError: it failed, or reports a load on board.
        """
        if vehicle_id in self.roster.failed():
            raise ValueError(f"{vehicle_id} has failed")
        view = self._agv_view(vehicle_id) or {}
        if view.get("loaded") is True:
            raise ValueError(f"{vehicle_id} is loaded: it delivers its load first")
        self.homeward.ask(vehicle_id)
        self._publish(SEND_HOME_PROPERTY, self.homeward.wire())

    def _publish(self, name: str, value: Any) -> None:
        """Set an observer's property, if the observer runs."""
        if self.observer is not None and not self.observer.closed:
            self.observer.update_node_property(name, value)

    def _publish_closed(self) -> None:
        """Publish the closed parts as the observer's property; every AGV follows it."""
        if self.observer is not None and not self.observer.closed:
            self.observer.update_node_property(CLOSED_PROPERTY, closed_wire(self.blocks.ways))

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
        vehicle = next((v for v in self.vehicles() if v.id == vehicle_id), None)
        if vehicle is None:
            raise KeyError(vehicle_id)
        props = self._agv_view(vehicle_id) or {}
        ahead = props.get("route")
        if vehicle.status == "failed" or not isinstance(ahead, list | tuple):
            return ()
        points = [
            (float(p[0]), float(p[1]))
            for p in ahead
            if isinstance(p, list | tuple)
            and len(p) == 2
            and all(isinstance(c, int | float) and not isinstance(c, bool) for c in p)
        ]
        return ((vehicle.x, vehicle.y), *points) if points else ()

    def nodes(self) -> Mapping[str, RoleActivator | RemoteNode]:
        """The observer and the transport base, and a read-only stand-in for every live
        AGV the observer hears (its node runs in its process; ``agv_app.fleet.remote``)."""
        out: dict[str, RoleActivator | RemoteNode] = {}
        for node in self._local_nodes():
            out[node.node_id] = node
        self._note_exits()
        out.update(self.roster.nodes())
        return out

    def _local_nodes(self) -> list[MeshNode]:
        return [n for n in (self.observer, self._base) if n is not None and not n.closed]

    def _traffic(self) -> tuple[int, int]:
        """Frames and bytes on the links of the nodes in this process, each frame once
        (on Zenoh, which keeps no per-link counters: what these nodes put and heard)."""
        local = {n.node_id: n for n in self._local_nodes()}
        messages = bytes_ = 0
        for node in local.values():
            if self.transport == "zenoh":
                counters = node.transport_counters()
                messages += counters.get("frames_out", 0) + counters.get("frames_in", 0)
                bytes_ += counters.get("bytes_out", 0) + counters.get("bytes_in", 0)
                continue
            for peer, stats in node.peer_stats().items():
                messages += stats.messages_out
                bytes_ += stats.bytes_out
                if peer not in local:
                    messages += stats.messages_in
                    bytes_ += stats.bytes_in
        return messages, bytes_

    def metrics(self) -> Mapping[str, float]:
        """Observed figures: tasks, traffic of this process's links, safety, stalls."""
        book = self.desk.book
        done = book.counts["done"]
        messages, bytes_ = self._traffic()
        self._note_exits()
        failed = self.roster.failed()
        hours = self.now / 3600.0
        return {
            "agvs": float(self._fleet_size() - len(failed) - len(self.roster.left())),
            "agvs_failed": float(len(failed)),
            "agvs_seen": float(len(self._agv_ids_heard())),
            "processes_running": float(self.processes.running()),
            "tasks_created": float(book.counts["created"]),
            "tasks_completed": float(done),
            "tasks_open": float(len(self.open_tasks)),
            "tasks_returned": float(self.desk.returned),
            "tasks_refused": float(self.desk.refused),
            "tasks_per_hour": done / hours if hours > 0 else 0.0,
            "free_flow_tasks_per_hour": self.free_flow.per_hour(self.now),
            "task_time_mean_s": book.durations.mean,
            "messages": float(messages),
            "bytes": float(bytes_),
            "collisions": float(self.monitor.collisions),
            "lock_overlaps": float(self.monitor.lock_overlaps),
            "deadlocks": float(self.stalls.deadlocks),
            "stalls_60s": float(self.stalls.long_waits),
            "max_wait": self.stalls.max_wait,
            **({} if self.broker_monitor is None else self.broker_monitor.status()),
        }

    def _fleet_size(self) -> int:
        """The AGVs spawned, or, joining a fleet, every AGV heard so far."""
        return len(self.roster.agv_ids) if self.joining else self.agv_count

    def set_speed(self, factor: float) -> None:
        """Only real time is possible: the AGVs are processes with their own clocks.

        Raises:
            ValueError: ``factor`` is not 1.0.
        """
        if factor != 1.0:
            raise ValueError(
                f"the AGVs run as real-time processes: speed is always 1.0, got {factor!r}"
            )

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
        self._advanced += seconds
        if self.arrivals is None or not self.automatic_tasks or not self.stations:
            return
        now = self.now
        if self._next_task_at is None:
            if len(self._agv_ids_heard()) < self.agv_count:
                return
            self._next_task_at = now
            for _ in range(self.start_tasks):
                self.desk.create_random()
        if now >= self._next_task_at:
            self.desk.create_random()
            self._next_task_at = self.arrivals.next_after(now)
