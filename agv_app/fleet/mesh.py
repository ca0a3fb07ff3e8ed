"""A fleet of AGV processes on the WebSocket mesh, seen through an observer node.

:class:`MeshFleet` implements the dashboard's ``FleetSource`` protocol (structurally,
like :class:`~agv_app.fleet.Fleet`) for ``objectplaces demo --processes N``. In the
dashboard's process it runs an observer node (no position, hears every node) and one
node per pick station (fixed nodes running the task-assignment initiator, as in the
simulated fleet), and it spawns every AGV as its own process
(:mod:`agv_app.fleet.agv_process`), all on 127.0.0.1. The mesh secret is generated per run
and handed to the children in a file only its owner can read, never on a command line.

Everything the fleet reports about the AGVs comes from what the observer hears: the
properties each AGV publishes (position, heading, hull length, state, task, and its
locked and requested projections). So the figures are *observed* ones: tasks created
here and seen done, traffic on the links of the nodes in this process, and a safety
check over the observed shapes, which is best effort (views lag the vehicles by the
publication interval, so only overlaps that last count).

``await fleet.start()`` before use and ``await fleet.stop()`` after (the dashboard's
app does both in its lifespan); ``stop`` terminates and reaps every child process.
"""

from __future__ import annotations

import asyncio
import contextlib
import math
import os
import random
import secrets
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from agv_app.fleet.metrics import FleetMetrics
from agv_app.fleet.sim import VehicleState
from agv_app.geometry import XY, Area, Pose, coords_to_polygon, hull
from agv_app.layout.demo import DEMO_VEHICLE_LENGTH_M, DEMO_VEHICLE_WIDTH_M, demo_warehouse
from agv_app.layout.graph import Layout
from agv_app.tasks.auction import TaskSpec
from agv_app.tasks.station import Station
from agv_app.traffic.collision import AGV_KIND
from agv_app.traffic.monitor import SafetyMonitor
from objectplaces import Initiator, RoleActivator
from objectplaces.mesh import MeshNode, start_node

__all__ = ["OBSERVER_ID", "MeshFleet", "parking_points"]

OBSERVER_ID = "observer"
"""Node id of the dashboard's observer node."""

_HOST = "127.0.0.1"
_CHECK_INTERVAL_S = 0.25
_SHRINK_M = 0.01  # more than the centimetre rounding of the wire form
_POLL_S = 0.05
_ROOT = str(Path(__file__).resolve().parents[2])


def parking_points(layout: Layout, n: int) -> list[str]:
    """Points to park ``n`` AGVs on: parking, then charging spots, spread over the plan.

    Raises:
        ValueError: the layout has fewer than ``n`` such spots.
    """
    points: list[str] = []
    for kind in ("parking", "charging"):
        for st in layout.stations_of_kind(kind):
            if st.id in layout.usable_stations() and st.point not in points:
                points.append(st.point)
    if len(points) < n:
        raise ValueError(f"layout {layout.name!r} has room to park {len(points)} AGVs, not {n}")
    # Spread the fleet over the spots rather than packing one corner.
    return [points[(k * len(points)) // n] for k in range(n)]


def _rings(coords: Any) -> tuple[tuple[XY, ...], ...]:
    """Exterior rings of a ``polygon_to_coords`` value, as vertex tuples."""
    out: list[tuple[XY, ...]] = []
    if not isinstance(coords, list | tuple):
        return ()
    for rings in coords:
        if not isinstance(rings, list | tuple) or not rings:
            continue
        flat = rings[0]
        if not isinstance(flat, list | tuple) or len(flat) < 6 or len(flat) % 2:
            continue
        try:
            out.append(tuple((float(flat[k]), float(flat[k + 1])) for k in range(0, len(flat), 2)))
        except (TypeError, ValueError):
            continue
    return tuple(out)


def _number(value: Any, default: float = 0.0) -> float:
    if isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value):
        return float(value)
    return default


class _Observed:
    """What the observer last heard of one AGV, with the shapes decoded once."""

    __slots__ = ("locked", "locked_area", "raw_locked", "raw_requested", "requested")

    def __init__(self) -> None:
        self.raw_locked: Any = None
        self.raw_requested: Any = None
        self.locked: tuple[tuple[XY, ...], ...] = ()
        self.requested: tuple[tuple[XY, ...], ...] = ()
        self.locked_area = Area.empty()

    def update(self, props: Mapping[str, Any]) -> None:
        locked, requested = props.get("locked"), props.get("requested")
        if locked is not self.raw_locked:
            self.raw_locked = locked
            self.locked = _rings(locked)
            try:
                self.locked_area = coords_to_polygon(locked) if locked else Area.empty()
            except (TypeError, ValueError):
                self.locked_area = Area.empty()
        if requested is not self.raw_requested:
            self.raw_requested = requested
            self.requested = _rings(requested)


class _Child:
    """One AGV process."""

    def __init__(self, agv_id: str, proc: subprocess.Popen[bytes]) -> None:
        self.agv_id = agv_id
        self.proc = proc


class MeshFleet:
    """A ``FleetSource`` over the WebSocket mesh: AGV processes, stations, an observer.

    Real-time processes cannot be paused: ``pause()`` stops issuing new automatic tasks
    (tasks created with ``create_task`` are still handed out, and the AGVs finish what
    they carry), and the speed is always 1.0.

    Args:
        agvs: number of AGV processes.
        seed: seeds the task generator and the processes.
        layout: must be the demo warehouse (the processes build it themselves); default.
        task_interval: mean seconds between automatic tasks, the first one as soon as
            every AGV is seen (None: no automatic tasks).
        t_update: property update interval of every node (the safe time is twice it).
        run_seconds: every AGV process stops by itself after this long.
        station_range: first auction range of the stations.
        dwell: seconds an AGV spends at a station.
        stop_timeout: how long ``stop`` waits for the processes after SIGTERM before
            it kills them.
        python: the interpreter that runs the AGV processes.
        capture_output: keep the children's stdout and stderr off this process's
            terminal (they go to files in the run's temp dir).

    Raises:
        ValueError: ``agvs`` < 1 or more AGVs than parking spots.
    """

    def __init__(
        self,
        *,
        agvs: int = 6,
        seed: int = 1,
        layout: Layout | None = None,
        task_interval: float | None = None,
        t_update: float = 1.0,
        run_seconds: float = 86_400.0,
        station_range: float = 30.0,
        dwell: float = 5.0,
        stop_timeout: float = 5.0,
        python: str = sys.executable,
        capture_output: bool = True,
    ) -> None:
        if agvs < 1:
            raise ValueError(f"agvs must be at least 1, got {agvs!r}")
        self.layout = layout or demo_warehouse()
        self.agv_count = agvs
        self.seed = seed
        self.task_interval = task_interval
        self.t_update = t_update
        self.run_seconds = run_seconds
        self.station_range = station_range
        self.dwell = dwell
        self.stop_timeout = stop_timeout
        self.python = python
        self.capture_output = capture_output
        self.homes = parking_points(self.layout, agvs)
        width = max(2, len(str(agvs)))
        self.agv_ids = [f"agv-{i + 1:0{width}d}" for i in range(agvs)]
        self.rng = random.Random(seed)
        self.metrics_raw = FleetMetrics()
        self.monitor = SafetyMonitor()
        self.observer: MeshNode | None = None
        self.stations: dict[str, Station] = {}
        self._station_nodes: dict[str, MeshNode] = {}
        self._children: list[_Child] = []
        self._tmpdir: Path | None = None
        self._watcher: asyncio.Task[None] | None = None
        self._started_at: float | None = None
        self._stopped = False
        self._paused = False
        self._advanced = 0.0
        self._next_task_at: float | None = None
        self._task_seq = 0
        self._tasks: dict[str, tuple[float, str | None]] = {}
        self._done: set[str] = set()
        self._observed: dict[str, _Observed] = {}
        self._suspects: dict[tuple[str, str, str], float] = {}
        self._counted: set[tuple[str, str, str]] = set()
        self._waiting_since: dict[str, float] = {}
        self._deadlocked: set[str] = set()
        self._checks = 0
        self._drops = [
            s
            for s in self.layout.usable_stations()
            if self.layout.station(s).kind in ("drop", "pickdrop")
        ]

    # -- life cycle -------------------------------------------------------------------

    @property
    def started(self) -> bool:
        """Whether ``start`` ran (and ``stop`` has not)."""
        return self._started_at is not None and not self._stopped

    def pids(self) -> list[int]:
        """Process ids of the AGV processes spawned (running or not)."""
        return [c.proc.pid for c in self._children]

    def exit_codes(self) -> dict[str, int | None]:
        """Each AGV process's exit status, by AGV id (None: still running)."""
        return {c.agv_id: c.proc.poll() for c in self._children}

    async def start(self) -> None:
        """Start the observer and station nodes and spawn the AGV processes.

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
        secret = secrets.token_hex(32).encode()
        self._tmpdir = Path(tempfile.mkdtemp(prefix="objectplaces-mesh-"))
        secret_file = self._tmpdir / "secret"
        fd = os.open(secret_file, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
        with os.fdopen(fd, "wb") as f:
            f.write(secret)
        node_args: dict[str, Any] = {
            "secret": secret,
            "property_interval": self.t_update,
            "failure_timeout": 3 * self.t_update,
        }
        observer = await start_node(OBSERVER_ID, listen=f"{_HOST}:0", **node_args)
        self.observer = observer
        observer.register_node_property_observer(self._on_property)
        join = [observer.address]
        for sid in self.layout.usable_stations():
            st = self.layout.station(sid)
            if st.kind not in ("pick", "pickdrop"):
                continue
            node = await start_node(f"st:{sid}", listen=f"{_HOST}:0", join=join, **node_args)
            self._station_nodes[sid] = node
            p = self.layout.point(st.point)
            self.stations[sid] = Station(
                node,
                sid,
                (p.x, p.y),
                range_m=self.station_range,
                on_assigned=self._assigned,
                tally=self.metrics_raw.tally,
            )
        peers = 1 + len(self._station_nodes) + self.agv_count - 1
        env = {**os.environ, "PYTHONUNBUFFERED": "1"}
        env["PYTHONPATH"] = os.pathsep.join(p for p in (_ROOT, env.get("PYTHONPATH")) if p)
        for i, (agv_id, home) in enumerate(zip(self.agv_ids, self.homes, strict=True)):
            command = [
                self.python, "-m", "agv_app.fleet.agv_process",
                "--id", agv_id,
                "--listen", f"{_HOST}:0",
                "--join", observer.address,
                "--secret-file", str(secret_file),
                "--home", home,
                "--seed", str(self.seed * 1000 + i),
                "--run-seconds", str(self.run_seconds),
                "--t-update", str(self.t_update),
                "--dwell", str(self.dwell),
                "--expect-peers", str(peers),
            ]  # fmt: skip
            self._children.append(_Child(agv_id, self._spawn(command, env, agv_id)))
        self._watcher = loop.create_task(self._watch(), name="mesh-fleet-watch")

    def _spawn(
        self, command: list[str], env: dict[str, str], agv_id: str
    ) -> subprocess.Popen[bytes]:
        out: Any = None
        if self.capture_output and self._tmpdir is not None:
            out = open(self._tmpdir / f"{agv_id}.log", "wb")  # noqa: SIM115 (closed below)
        try:
            # Its own session: a Ctrl-C at the terminal reaches the dashboard only, and
            # the dashboard stops its children in order. The stdin pipe stays open for
            # the child's whole life; its end of file tells the child we are gone.
            return subprocess.Popen(
                command,
                env=env,
                stdin=subprocess.PIPE,
                stdout=out if out is not None else subprocess.DEVNULL,
                stderr=out if out is not None else None,
                start_new_session=True,
                close_fds=True,
            )
        finally:
            if out is not None:
                out.close()

    async def wait_ready(self) -> None:
        """Wait until the observer has heard every AGV's position (bound it with
        ``asyncio.timeout``; :meth:`missing` names who is still unheard).

        Raises:
            RuntimeError: an AGV process has exited.
        """
        while self.missing():
            dead = [c.agv_id for c in self._children if c.proc.poll() is not None]
            if dead:
                raise RuntimeError(f"AGV processes exited: {', '.join(dead)}")
            await asyncio.sleep(0.1)

    def missing(self) -> list[str]:
        """Ids of the AGVs the observer has not heard yet."""
        seen = {n for n, _ in self._agv_views()}
        return [a for a in self.agv_ids if a not in seen]

    def child_logs(self) -> dict[str, str]:
        """The captured output of every AGV process so far (for diagnostics)."""
        out: dict[str, str] = {}
        if self._tmpdir is None:
            return out
        for child in self._children:
            path = self._tmpdir / f"{child.agv_id}.log"
            with contextlib.suppress(OSError):
                out[child.agv_id] = path.read_text(errors="replace")
        return out

    async def stop(self) -> None:
        """Stop everything: terminate and reap every AGV process, close the nodes.

        The children get end of file on stdin and SIGTERM, and ``stop_timeout``
        seconds to leave the mesh; whoever is left then is killed. Idempotent.
        """
        if self._stopped:
            return
        self._stopped = True
        watcher, self._watcher = self._watcher, None
        if watcher is not None:
            watcher.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await watcher
        await self._reap()
        for node in [*self._station_nodes.values(), *([self.observer] if self.observer else [])]:
            await node.close()
        if self._tmpdir is not None:
            shutil.rmtree(self._tmpdir, ignore_errors=True)
            self._tmpdir = None

    async def _reap(self) -> None:
        children = [c.proc for c in self._children]
        for proc in children:
            if proc.stdin is not None:
                with contextlib.suppress(OSError):
                    proc.stdin.close()
            if proc.poll() is None:
                with contextlib.suppress(ProcessLookupError):
                    proc.send_signal(signal.SIGTERM)
        deadline = time.monotonic() + self.stop_timeout
        for _ in range(math.ceil(self.stop_timeout / _POLL_S) + 1):
            if all(p.poll() is not None for p in children) or time.monotonic() >= deadline:
                break
            await asyncio.sleep(_POLL_S)
        for proc in children:
            if proc.poll() is None:
                with contextlib.suppress(ProcessLookupError):
                    proc.kill()
        for proc in children:
            # After SIGKILL the wait is short; bounded all the same.
            with contextlib.suppress(subprocess.TimeoutExpired):
                proc.wait(timeout=5.0)

    # -- observing --------------------------------------------------------------------

    def _on_property(self, node_id: str, name: str, value: Any) -> None:
        if name != "last_done" or not isinstance(value, str):
            return
        if value not in self._tasks or value in self._done:
            return
        self._done.add(value)
        created, _ = self._tasks[value]
        self.metrics_raw.tasks_completed += 1
        self.metrics_raw.task_times.append(self.now - created)

    def _agv_views(self) -> list[tuple[str, Mapping[str, Any]]]:
        if self.observer is None or self.observer.closed:
            return []
        view = self.observer.view()
        return [
            (n, view[n])
            for n in sorted(view)
            if view[n].get("kind") == AGV_KIND and isinstance(view[n].get("position"), tuple)
        ]

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
        self._checks += 1
        vehicles = self.vehicles()
        hulls = [
            (
                v.id,
                hull(Pose(v.x, v.y, v.heading_rad), length=v.length_m, width=v.width_m).buffer(
                    -_SHRINK_M
                ),
            )
            for v in vehicles
        ]
        locks = [
            (v.id, self._observed[v.id].locked_area.buffer(-_SHRINK_M))
            for v in vehicles
            if v.id in self._observed
        ]
        found = SafetyMonitor(tolerance_m2=self.monitor.tolerance_m2).check(
            self._checks, now, hulls, locks
        )
        current = {(v.kind, *v.agvs): v for v in found}
        self._suspects = {k: self._suspects.get(k, now) for k in current}
        for key, since in self._suspects.items():
            if now - since >= 2 * self.t_update and key not in self._counted:
                self._counted.add(key)
                if key[0] == "collision":
                    self.monitor.collisions += 1
                else:
                    self.monitor.lock_overlaps += 1
                if len(self.monitor.violations) < self.monitor.keep:
                    self.monitor.violations.append(current[key])
        self._counted &= set(current)
        for v in vehicles:
            if v.status != "waiting":
                self._waiting_since.pop(v.id, None)
                self._deadlocked.discard(v.id)
                continue
            since = self._waiting_since.setdefault(v.id, now)
            if now - since > 180.0 and v.id not in self._deadlocked:
                self._deadlocked.add(v.id)
                self.metrics_raw.deadlocks += 1

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
        station = self.stations.get(station_id)
        if station is None:
            raise ValueError(f"station {station_id!r} is not a pick station")
        if drop is None:
            choices = [d for d in self._drops if d != station_id]
            drop = choices[self.rng.randrange(len(choices))]
        self._task_seq += 1
        task = TaskSpec(f"task-{self._task_seq}", station_id, drop)
        self._tasks[task.id] = (self.now, None)
        self.metrics_raw.tasks_created += 1
        station.add_task(task)
        return task.id

    def _assigned(self, task: TaskSpec, agv: str) -> None:
        created, _ = self._tasks.get(task.id, (self.now, None))
        self._tasks[task.id] = (created, agv)

    def assignment(self, task_id: str) -> str | None:
        """The AGV a task was awarded to (None: not yet, or unknown)."""
        return self._tasks.get(task_id, (0.0, None))[1]

    @property
    def open_tasks(self) -> list[str]:
        """Ids of tasks created and not seen done."""
        return [t for t in self._tasks if t not in self._done]

    # -- FleetSource ----------------------------------------------------------------------

    def layout_view(self) -> Layout:
        """The floor plan."""
        return self.layout

    def vehicles(self) -> Sequence[VehicleState]:
        """Every AGV the observer hears, by id, as it last heard it."""
        out: list[VehicleState] = []
        for agv_id, props in self._agv_views():
            x, y = (_number(c) for c in props["position"][:2])
            heading = _number(props.get("heading"))
            size = props.get("size")
            length, width = DEMO_VEHICLE_LENGTH_M, DEMO_VEHICLE_WIDTH_M
            if isinstance(size, list | tuple) and len(size) == 2:
                length, width = _number(size[0], length), _number(size[1], width)
            seen = self._observed.get(agv_id)
            if seen is None:
                seen = self._observed[agv_id] = _Observed()
            seen.update(props)
            ring = list(hull(Pose(x, y, heading), length=length, width=width).geom.exterior.coords)
            state = props.get("state", props.get("status"))
            task = props.get("task")
            out.append(
                VehicleState(
                    agv_id,
                    x,
                    y,
                    heading,
                    length,
                    width,
                    state if isinstance(state, str) else "unknown",
                    task if isinstance(task, str) else None,
                    tuple((float(px), float(py)) for px, py in ring[:-1]),
                    _number(props.get("hull_length")),
                    seen.locked,
                    seen.requested,
                )
            )
        return out

    def nodes(self) -> Mapping[str, RoleActivator]:
        """The nodes in this process: the observer and the stations (the AGVs are
        remote; the observer's view shows them)."""
        out: dict[str, RoleActivator] = {}
        if self.observer is not None and not self.observer.closed:
            out[OBSERVER_ID] = self.observer
        for node in self._station_nodes.values():
            if not node.closed:
                out[node.node_id] = node
        return out

    @property
    def observer_id(self) -> str:
        """The dashboard's observer node (no position)."""
        return OBSERVER_ID

    def initiator_roles(self) -> Mapping[str, Callable[[Mapping[str, Any]], Initiator]]:
        """None: locks and awards belong to the fleet's own components."""
        return {}

    def _traffic(self) -> tuple[int, int]:
        """Frames and bytes on the links of the nodes in this process, each frame once."""
        local = self.nodes()
        messages = bytes_ = 0
        for node in local.values():
            if not isinstance(node, MeshNode):
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
        m = self.metrics_raw
        m.tasks_returned = sum(s.returned for s in self.stations.values())
        messages, bytes_ = self._traffic()
        hours = self.now / 3600.0
        times = m.task_times
        return {
            "agvs": float(self.agv_count),
            "agvs_seen": float(len(self._agv_views())),
            "processes_running": float(sum(c.proc.poll() is None for c in self._children)),
            "tasks_created": float(m.tasks_created),
            "tasks_completed": float(m.tasks_completed),
            "tasks_open": float(len(self.open_tasks)),
            "tasks_returned": float(m.tasks_returned),
            "tasks_per_hour": m.tasks_completed / hours if hours > 0 else 0.0,
            "task_time_mean_s": sum(times) / len(times) if times else 0.0,
            "messages": float(messages),
            "bytes": float(bytes_),
            "collisions": float(self.monitor.collisions),
            "lock_overlaps": float(self.monitor.lock_overlaps),
            "deadlocks": float(m.deadlocks),
        }

    def pause(self) -> None:
        """Stop issuing automatic tasks (the AGV processes run in real time and go on)."""
        self._paused = True

    def resume(self) -> None:
        """Issue automatic tasks again."""
        self._paused = False

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
    def paused(self) -> bool:
        """True between ``pause()`` and ``resume()`` (no new automatic tasks)."""
        return self._paused

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
        if self.task_interval is None or self._paused or not self.stations:
            return
        now = self.now
        if self._next_task_at is None:
            if len(self._agv_views()) < self.agv_count:
                return
            self._next_task_at = now
        if now >= self._next_task_at:
            sids = sorted(self.stations)
            self.create_task(sids[self.rng.randrange(len(sids))])
            self._next_task_at = now + self.rng.expovariate(1.0 / self.task_interval)
