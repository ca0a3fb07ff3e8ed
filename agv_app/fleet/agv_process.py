"""One AGV as its own process on the WebSocket mesh or on Zenoh.

```
python -m agv_app.fleet.agv_process --id agv-03 --listen 127.0.0.1:0 --join 127.0.0.1:7000 \\
    --pki fleet-pki --home P0350n --seed 3 [--run-seconds 600]
```

``--pki D`` joins with mutual TLS as the certificate ``D/ID.pem`` names; ``--insecure
--secret-file F`` with plain links, on loopback only. ``--driver sim|standin`` picks the
vehicle's driver; ``--state-dir DIR`` keeps its pose and the task it holds there, so a
restarted process comes back where the vehicle stands (:mod:`agv_app.fleet.restart_state`,
docs/drivers.md).

The process starts a node, builds an :class:`~agv_app.vehicle.controller.AgvController` on the
demo warehouse and steps it in real time (fixed ``--dt``). Besides what the controller
publishes as properties (position and hull length at every request and release,
status, task, last done), it shows the observer, over the observer's display session
(:mod:`agv_app.fleet.display_feed`), what it needs to draw the vehicle, each only when
it changes: ``position`` and ``heading`` (radians) as it moves, ``state`` (the
dashboard's finer status), ``speed`` (m/s, 0 only standing), ``held`` (it holds for
the control's stop, :mod:`agv_app.fleet.holding`), ``in_service``, ``loaded`` (it
carries its task's load: it is not sent home, :mod:`agv_app.fleet.sending_home`),
``battery`` (with ``--battery``: its state of charge, percent), ``size``
(``[length, width]``), ``locked`` and ``requested`` (its projections in the compact form
of :func:`~agv_app.geometry.polygon_to_coords`) and ``route`` (the vertices ahead); and
what the dashboard shows of its node:
``sessions``, ``roles`` and ``traffic`` (:mod:`agv_app.fleet.remote`).

It stops by itself, always through a graceful ``node.close()``: when ``--run-seconds``
pass, when its stdin (a pipe from its parent) closes, when its parent process dies, on
SIGTERM or SIGINT, or when its vehicle's driver fails (its pose reports stop: the
vehicle is told to stop, the goodbye tells the others to keep its last circle; exit
status 3, for a supervisor to restart it). Output is one JSON object per line on stdout
(``ready`` with the ``position`` the vehicle stands at, ``driving``, ``lag`` every 5 s
while driving and ``closed``, both with how late its control steps ran so far:
``steps``, ``late_steps`` late by more than ``--dt``, ``max_lag_s``; ``fault`` with its
``reason``; ``stopping``); errors go to stderr.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import functools
import json
import math
import os
import random
import signal
import stat
import sys
import time
from pathlib import Path
from typing import Any

from agv_app.fleet.closed_listener import ClosedListener
from agv_app.fleet.display_feed import DISPLAY_ROLE, DisplayFeed
from agv_app.fleet.holding import HoldListener
from agv_app.fleet.liveness import (
    REPUBLISH_BEATS,
    REST_BEAT_S,
    fleet_liveness,
    liveness_arguments,
    rest_beat_argument,
)
from agv_app.fleet.parking import home_heading
from agv_app.fleet.remote import roles_wire, sessions_wire, traffic_wire
from agv_app.fleet.restart_state import TaskKeeper, add_driver_arguments, held_task, vehicle_driver
from agv_app.fleet.sending_home import SendHomeListener
from agv_app.fleet.trace import VehicleTrace
from agv_app.fleet.view import OBSERVER_ID
from agv_app.geometry import Area, Pose, polygon_to_coords
from agv_app.layout.choice import layout_digest, layout_from_argument
from agv_app.layout.demo import DEMO_VEHICLE_LENGTH_M, DEMO_VEHICLE_WIDTH_M
from agv_app.layout.elements import LayoutError
from agv_app.layout.graph import Layout
from agv_app.traffic.reach import interest_radius
from agv_app.traffic.stale_relay import StaleListener, StaleRelay
from agv_app.vda5050.link import BrokerError, MqttLink, check_broker
from agv_app.vda5050.process import bridge_for, vehicle_class, vehicle_link
from agv_app.vehicle.battery import BatterySpec
from agv_app.vehicle.battery_drain import BatteryDrain
from agv_app.vehicle.comeback import announce, hand_back
from agv_app.vehicle.controller import AgvConfig, AgvController
from agv_app.vehicle.kinematics import VehicleSpec
from agv_app.vehicle.service import loaded, send_home
from objectplaces.arguments import POSITIVE, number, whole
from objectplaces.core.config import NodeConfig
from objectplaces.core.errors import LocalProtocolError
from objectplaces.mesh import MeshNode, start_node
from objectplaces.security import (
    CredentialError,
    Credentials,
    add_credential_arguments,
    credentials_from_args,
)
from objectplaces.space_pages import serve_space
from objectplaces.zenoh_node import ZenohNode, start_zenoh_node

__all__ = [
    "AnotherFleet",
    "DisplayPublisher",
    "StepLag",
    "add_agv_arguments",
    "build_parser",
    "dissemination_radius",
    "main",
    "parse_args",
    "process_liveness",
    "register",
    "run",
]

_PARENT_CHECK_S = 1.0
_SETTLE_REPORT_S = 10.0
_TWIN_AFTER_S = 15.0
"""Seconds another run's token of our id may stay up: a crashed run's lasts the lease
(10 s), and then some for a loaded machine."""
_RETRY_FIRST_S = 0.5
_RETRY_MAX_S = 10.0
_MAX_LAG_S = 1.0
_LAG_EVERY_S = 5.0
POLL_INTERVAL_S = 0.05
"""On Zenoh, received frames are handed to the node together every this many seconds
(half the control step): one wake-up for several frames instead of two each. Ten AGV
processes beside ten others, same run: 27.7 ms of CPU a second each against 31.5 with
0.025 s. The frames wait up to this long, well inside the second of delay the interest
radius allows for (``_MAX_LAG_S``)."""
PROFILE_ENV = "OBJECTPLACES_AGV_PROFILE"
"""A directory: each AGV process profiles its event loop's thread (cProfile, in thread
CPU time) and writes ``<id>.prof`` there when it stops. Off by default."""


def process_liveness(
    t_update: float, republish_beats: int = REPUBLISH_BEATS, rest_beat: float | None = REST_BEAT_S
) -> NodeConfig:
    """Liveness by beats, as the simulated fleet runs it (``fleet_liveness``): a beat of a
    few bytes after ``t_update`` without a publication, every ``rest_beat`` while parked
    idle, every property again only every ``republish_beats`` beats (0: no beats, every
    property republished each ``t_update``)."""
    republish = republish_beats * t_update if republish_beats > 0 else None
    return fleet_liveness(t_update, republish=republish, rest_beat=rest_beat)


def _emit(event: str, **fields: Any) -> None:
    """Print one event as a JSON line on stdout."""
    record = {"event": event, "t": time.monotonic(), **fields}
    sys.stdout.write(json.dumps(record, default=repr) + "\n")
    sys.stdout.flush()


def _area_coords(areas: list[Area]) -> list[list[list[float]]]:
    # Display and monitoring only: no safety margin, the observer never votes with it.
    return polygon_to_coords(Area.union_of(areas), margin_m=0.0)


class _AreaCoords:
    """``_area_coords`` of the last areas asked for, worked out again only when they
    change: the lock book hands out the same area objects until a lock or request moves,
    and the union of their polygons is most of a publication's cost."""

    __slots__ = ("_areas", "_coords")

    def __init__(self) -> None:
        self._areas: list[Area] = []
        self._coords: list[list[list[float]]] = []

    def __call__(self, areas: list[Area]) -> list[list[list[float]]]:
        known = self._areas
        if len(areas) != len(known) or any(a is not b for a, b in zip(areas, known, strict=True)):
            self._areas = list(areas)  # held, so no other object can take their ids
            self._coords = _area_coords(areas)
        return self._coords


def dissemination_radius(
    choice: str | float,
    layout: Layout,
    spec: VehicleSpec,
    config: AgvConfig,
    liveness: NodeConfig,
) -> float | None:
    """The interest radius of an AGV node for ``--interest-radius`` (None: hear every
    node). ``auto``: from the layout's largest hull projection and the nodes' failure
    detection (``liveness``), or None when that spans the whole layout."""
    if choice == "none":
        return None
    if choice != "auto":
        return float(choice)
    # A loaded machine delays frames by up to the largest step lag. The demo floor
    # lies within this radius, so no failure needs relaying (traffic/stale_relay.py).
    detection = liveness.failure_detection_bound
    assert detection is not None  # a failure timeout is set
    radius = interest_radius(
        layout, spec, config, delay_s=_MAX_LAG_S, failure_detection_s=detection
    )
    # Every node on such a floor lies within the radius of every other: scoping would
    # leave nobody out, and one subscription to everything costs a receiver less than a
    # subscriber per row of cells (docs/zenoh.md, "Keys").
    return None if radius >= layout.diagonal() else radius


def _route_ahead(agv: AgvController) -> list[list[float]]:
    """The vertices of the route still ahead (to centimetres), the last where it stops;
    empty at rest or failed. Changes only at a vertex or with a new route."""
    vehicle = agv.vehicle
    if agv.failed or vehicle.remaining() <= 1e-9:
        return []
    ahead = vehicle.route.slice(vehicle.s, vehicle.route.length).coords[1:]
    return [[round(x, 2), round(y, 2)] for x, y in ahead]


class DisplayPublisher:
    """Shows the observer what it needs to draw one AGV, and what the dashboard shows
    of its node (``agv_app.fleet.remote``), each only on change, over the observer's
    display session (:mod:`agv_app.fleet.display_feed`), not to every node that hears
    the AGV.

    Args:
        agv: the AGV component (its node plays the display role).
        min_move_m: show the pose again when the vehicle moved at least this far.
        traffic_interval_s: least time between two reports of the node's introspection
            (sessions, roles, traffic), which change with every request.
    """

    def __init__(
        self, agv: AgvController, *, min_move_m: float = 0.01, traffic_interval_s: float = 1.0
    ) -> None:
        self.agv = agv
        self.min_move_m = min_move_m
        self.traffic_interval_s = traffic_interval_s
        self.feed = DisplayFeed()
        self._next_traffic = -math.inf
        self._pose: tuple[float, float, float] | None = None
        self._locked = _AreaCoords()
        self._requested = _AreaCoords()
        agv.node.set_participant_factory(DISPLAY_ROLE, self.feed.reporter)
        self.feed.set("size", [agv.spec.length_m, agv.spec.width_m])

    def publish(self) -> None:
        """Show the pose, state and projections, and send what changed."""
        agv, feed = self.agv, self.feed
        if agv.failed:
            return
        pose = agv.vehicle.pose()
        heading = round(math.remainder(pose.heading_rad, math.tau), 3)
        last = self._pose
        if (
            last is None
            or math.hypot(pose.x - last[0], pose.y - last[1]) >= self.min_move_m
            or heading != last[2]
        ):
            self._pose = (pose.x, pose.y, heading)
            feed.set("position", [round(pose.x, 3), round(pose.y, 3)])
            feed.set("heading", heading)
        # The task with the state: the observer learns that the AGV set off with it
        # from one report, whatever the order of the property stream and the channel.
        feed.set("task", agv.node.properties.get("task"))
        feed.set("state", agv.display_status())
        speed = agv.vehicle.speed
        # Standing is exactly 0; any motion shows as at least 0.1 m/s.
        feed.set("speed", 0.0 if speed == 0.0 else max(0.1, round(speed, 1)))
        feed.set("held", agv.held)
        feed.set("in_service", agv.in_service)
        feed.set("loaded", loaded(agv))  # it cannot be sent home while loaded
        if agv.battery is not None:
            feed.set("battery", round(agv.battery.state_of_charge(agv.node.now()), 3))
        locks, request = agv.areas()
        feed.set("locked", self._locked(locks))
        feed.set("requested", self._requested([] if request is None else [request]))
        feed.set("route", _route_ahead(agv))
        self.publish_introspection()
        feed.flush()

    def publish_introspection(self) -> None:
        """Show the sessions, roles and traffic of the node, each on change, at most
        every ``traffic_interval_s``: what the dashboard shows of a node.

        Not the traffic while the AGV is at rest: its counters change with every frame
        it hears, its own reports included, so it would report every interval for as
        long as it stands. The dashboard shows a parked AGV's traffic as of when it
        parked."""
        node, feed = self.agv.node, self.feed
        now = node.now()
        if now >= self._next_traffic:
            self._next_traffic = now + self.traffic_interval_s
            feed.set("sessions", sessions_wire(node.sessions()))
            feed.set("roles", roles_wire(node.participations()))
            if not self.agv.at_rest:
                feed.set("traffic", traffic_wire(node.stats()))


def build_parser() -> argparse.ArgumentParser:
    """The command line's parser (``parse_args`` also checks ``--interest-radius``)."""
    parser = argparse.ArgumentParser(
        prog="python -m agv_app.fleet.agv_process",
        description="Run one AGV as a node of its fleet (the process behind `objectplaces agv`).",
    )
    add_agv_arguments(parser)
    return parser


def add_agv_arguments(parser: argparse.ArgumentParser, *, joining: bool = False) -> None:
    """The options of one AGV process (``joining``: the defaults of ``objectplaces agv``,
    which waits for the fleet before it drives)."""
    parser.add_argument("--id", required=True, help="node id of the AGV, unique in the mesh")
    parser.add_argument(
        "--layout",
        help="the layout it drives: a .json or openTCS .xml file, generated:N, or demo "
        "(default: the demo warehouse); every process of a fleet must run the same one",
    )
    parser.add_argument("--listen", default="127.0.0.1:0", help="host:port to listen on")
    parser.add_argument(
        "--join", action="append", default=[], metavar="HOST:PORT", help="a node to join through"
    )
    parser.add_argument(
        "--transport", choices=["websocket", "zenoh"], default="websocket", help="how nodes talk"
    )
    parser.add_argument(
        "--connect",
        action="append",
        default=[],
        metavar="ENDPOINT",
        help="a node to join through (the mesh), or a router or peer (zenoh); repeatable",
    )
    parser.add_argument(
        "--mode", choices=["peer", "client"], default="peer", help="zenoh: peer or client"
    )
    parser.add_argument(
        "--poll-interval",
        type=number(at_least=0, at_most=1),
        default=POLL_INTERVAL_S,
        help="zenoh: hand received frames on every this many s (0: each at once)",
    )
    parser.add_argument(
        "--republish-beats",
        type=whole(at_least=0),
        default=REPUBLISH_BEATS,
        help="liveness beats between republications (0: republish every t-update)",
    )
    parser.add_argument(
        "--rest-beat",
        type=rest_beat_argument,
        default=REST_BEAT_S,
        metavar="S|none",
        help=f"beat every S seconds while parked at home with no task (default "
        f"{REST_BEAT_S:g}; 'none': every t-update)",
    )
    add_credential_arguments(parser)
    parser.add_argument("--home", required=True, help="layout point of the AGV's parking spot")
    add_driver_arguments(parser)
    parser.add_argument("--seed", type=int, default=1, help="seeds the start-up stagger")
    parser.add_argument("--run-seconds", type=POSITIVE, default=86_400.0, help="stop after this")
    parser.add_argument("--dt", type=POSITIVE, default=0.1, help="control step, s")
    parser.add_argument("--t-update", type=POSITIVE, default=1.0, help="property interval, s")
    parser.add_argument("--publish-interval", type=POSITIVE, default=0.2, help="pose updates, s")
    parser.add_argument(
        "--introspection-interval",
        type=POSITIVE,
        default=1.0,
        help="least time between two publications of sessions, roles and traffic, s",
    )
    parser.add_argument(
        "--expect-peers",
        type=whole(at_least=0),
        default=1 if joining else 0,
        help="wait for this many linked peers before driving",
    )
    parser.add_argument(
        "--settle-timeout",
        type=number(at_least=0),
        default=None if joining else 20.0,
        help="longest wait for those peers, s (then it drives; default: "
        + ("for ever, saying so every 10 s)" if joining else "20)"),
    )
    parser.add_argument(
        "--dwell", type=number(at_least=0), default=5.0, help="seconds at a station"
    )
    parser.add_argument(
        "--battery",
        action="store_true",
        help="a battery (BatterySpec's defaults) that drains as the vehicle drives and is "
        "reported (``battery``, VDA 5050 powerSupply); no charging",
    )
    parser.add_argument(
        "--interest-radius",
        default="auto",
        help="scoped dissemination radius, m; 'auto' (default): from the layout's largest "
        "hull projection (agv_app.traffic.reach), or 'none' when that spans the whole "
        "layout; 'none': hear every node",
    )
    parser.add_argument(
        "--trace",
        type=Path,
        metavar="FILE",
        help="write the vehicle's own safety trace here (JSON lines: poses, locks at each "
        "change, metres outside its locked floor; agv_app.fleet.trace)",
    )
    parser.add_argument(
        "--vda5050",
        default=None,
        metavar="mqtts://HOST:PORT",
        help="speak VDA 5050 over MQTT with the certificate of --pki (mqtt:// only with "
        "--insecure, on loopback)",
    )


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Parse the command line (``sys.argv[1:]`` when ``argv`` is None)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.interest_radius not in ("auto", "none"):
        try:
            args.interest_radius = POSITIVE(args.interest_radius)
        except argparse.ArgumentTypeError:
            parser.error("--interest-radius must be 'auto', 'none' or a number > 0")
    return args


async def _watch_stdin(stop: asyncio.Event) -> None:
    """Set ``stop`` when stdin, a pipe from the parent, reaches end of file."""
    try:
        if not stat.S_ISFIFO(os.fstat(sys.stdin.fileno()).st_mode):
            return  # a terminal or /dev/null: nobody holds it open for us
    except (OSError, ValueError):
        return
    loop = asyncio.get_running_loop()
    reader = asyncio.StreamReader(limit=1 << 16)
    try:
        transport, _ = await loop.connect_read_pipe(
            lambda: asyncio.StreamReaderProtocol(reader), sys.stdin
        )
    except (OSError, ValueError):
        return
    try:
        while True:
            try:
                line = await reader.readline()
            except ValueError:
                continue  # a line too long: ignored, nothing is read from stdin
            if not line:
                stop.set()
                return
    finally:
        transport.close()


async def _watch_twin(node: MeshNode | ZenohNode, args: argparse.Namespace) -> None:
    """Return when another process has run as this vehicle's id past a dead run's
    lease (on Zenoh, where every run holds a token): this one must give way."""
    if not isinstance(node, ZenohNode):
        await asyncio.Event().wait()  # for ever: the mesh keeps the newer run's links
        return
    while True:
        await asyncio.sleep(1.0)
        twin = node.twin_up_for()
        if twin is not None and twin > _TWIN_AFTER_S:
            return


async def _watch_parent(stop: asyncio.Event, parent: int) -> None:
    """Set ``stop`` when the parent process is gone (we were re-parented)."""
    while True:
        await asyncio.sleep(_PARENT_CHECK_S)
        if os.getppid() != parent:
            stop.set()
            return


class AnotherFleet(Exception):
    """The peers this process reached run another layout: it may not join them."""


async def _settle(node: MeshNode | ZenohNode, args: argparse.Namespace) -> None:
    """Wait (bounded by ``--settle-timeout``) until the expected peers are linked and
    have been heard, saying every ``_SETTLE_REPORT_S`` what it waits for.

    Moving earlier is safe (the requester waits the safe time for late members), but
    an AGV that has not yet heard its neighbours would ask fewer of them than it should.

    Raises:
        AnotherFleet: a peer refused our link for running another layout.
    """
    loop = asyncio.get_running_loop()
    deadline = loop.time() + (math.inf if args.settle_timeout is None else args.settle_timeout)
    while len(node.peers()) < args.expect_peers and loop.time() < deadline:
        refusals = node.refusals()
        foreign = [f"{where}: {why}" for where, why in refusals.items() if "another fleet" in why]
        if foreign:
            raise AnotherFleet("; ".join(foreign))
        _emit(
            "waiting",
            peers=node.peers(),
            expected=args.expect_peers,
            connect=[*args.join, *args.connect],
            refusals=refusals,
        )
        with contextlib.suppress(TimeoutError):
            async with asyncio.timeout(min(_SETTLE_REPORT_S, max(0.0, deadline - loop.time()))):
                await node.wait_for_peers(args.expect_peers)
    await asyncio.sleep(args.t_update)


async def _open_zenoh(
    args: argparse.Namespace,
    credentials: Credentials,
    tag: str,
    timing: dict[str, Any],
    stop: asyncio.Event,
) -> ZenohNode | None:
    """Open the node's Zenoh session; while no router or peer of ``--connect`` can be
    reached, say so and try again, backing off up to ``_RETRY_MAX_S`` (None: told to
    stop meanwhile)."""
    delay = _RETRY_FIRST_S
    while True:
        try:
            return await start_zenoh_node(
                args.id,
                tls=credentials.tls,
                insecure=credentials.insecure,
                secret=credentials.secret,
                connect=args.connect,
                mode=args.mode,
                poll_interval=args.poll_interval or None,
                tag=tag,
                **timing,
            )
        except OSError as exc:
            _emit("unreachable", connect=args.connect, error=str(exc), retry_in_s=delay)
            print(
                f"{_who(args)}: cannot reach {', '.join(args.connect)} yet ({exc}); "
                f"trying again in {delay:g} s",
                file=sys.stderr,
            )
        with contextlib.suppress(TimeoutError):
            async with asyncio.timeout(delay):
                await stop.wait()
                return None
        delay = min(_RETRY_MAX_S, delay * 2)


class StepLag:
    """How late the control steps ran: whether the process keeps real time."""

    __slots__ = ("late_steps", "max_lag_s", "steps")

    def __init__(self) -> None:
        self.steps = 0
        self.late_steps = 0
        self.max_lag_s = 0.0

    def note(self, lag_s: float, dt: float) -> None:
        """A step ran ``lag_s`` seconds after its time (late: by more than ``dt``)."""
        self.steps += 1
        self.late_steps += lag_s > dt
        self.max_lag_s = max(self.max_lag_s, lag_s)

    def fields(self) -> dict[str, Any]:
        """The figures, for the ``closed`` event."""
        return {"steps": self.steps, "late_steps": self.late_steps, "max_lag_s": self.max_lag_s}


async def _drive(
    agv: AgvController,
    display: DisplayPublisher,
    args: argparse.Namespace,
    lag: StepLag,
    trace: VehicleTrace | None = None,
    keeper: TaskKeeper | None = None,
) -> None:
    """Step the AGV every ``dt`` of real time, noting how late each step ran, until its
    vehicle's driver fails."""
    drain = BatteryDrain(agv)
    loop = asyncio.get_running_loop()
    dt = args.dt
    # Processes started together would otherwise step (and publish) in lockstep.
    await asyncio.sleep(random.Random(args.seed).uniform(0.0, dt))
    next_step = loop.time()
    next_publish = next_step
    next_lag_report = next_step + _LAG_EVERY_S
    while True:
        lag.note(loop.time() - next_step, dt)
        agv.step(dt)
        drain.step(dt)
        if trace is not None:
            trace.step()
        if keeper is not None:
            keeper.note(agv)
        if agv.failed:
            return
        now = loop.time()
        if now >= next_lag_report:
            next_lag_report = now + _LAG_EVERY_S
            _emit("lag", **lag.fields())
        if now >= next_publish:
            next_publish = now + args.publish_interval
            display.publish()
        next_step += dt
        if now - next_step > _MAX_LAG_S:
            # Fallen far behind (a stalled machine): carry on from now, no burst of steps.
            next_step = now
        await asyncio.sleep(max(0.0, next_step - loop.time()))


async def run(args: argparse.Namespace, credentials: Credentials) -> int:
    """Run one AGV process until one of its stop conditions.

    Args:
        args: the parsed command line.
        credentials: how it joins (mutual TLS, or plain links on loopback).

    Returns:
        The exit status (0 after a graceful stop).
    """
    try:
        layout = layout_from_argument(args.layout)
    except (LayoutError, ValueError, OSError) as exc:
        print(f"{_who(args)}: --layout: {exc}", file=sys.stderr)
        return 2
    if args.home not in layout.points:
        print(
            f"{_who(args)}: --home {args.home!r} is no point of layout {layout.name!r}",
            file=sys.stderr,
        )
        return 2
    tag = f"layout:{layout_digest(layout)}"
    vda5050: MqttLink | None = None
    if args.vda5050 is not None:
        try:
            vda5050 = vehicle_link(args.vda5050, credentials, args.id)
            await check_broker(vda5050)
        except (ValueError, LocalProtocolError, BrokerError) as exc:
            print(f"{_who(args)}: --vda5050: {exc}", file=sys.stderr)
            return 2
    parent = os.getppid()
    loop = asyncio.get_running_loop()
    stop = asyncio.Event()
    for signum in (signal.SIGTERM, signal.SIGINT):
        loop.add_signal_handler(signum, stop.set)
    # From the start: a process still waiting for a router stops by itself too.
    loop.call_later(args.run_seconds, stop.set)
    spec = VehicleSpec(
        DEMO_VEHICLE_LENGTH_M,
        DEMO_VEHICLE_WIDTH_M,
        battery=BatterySpec() if args.battery else None,
    )
    config = AgvConfig(t_update=args.t_update, dwell=args.dwell)
    liveness = process_liveness(args.t_update, args.republish_beats, args.rest_beat)
    timing: dict[str, Any] = {
        **liveness_arguments(liveness),
        "interest_radius": dissemination_radius(
            args.interest_radius, layout, spec, config, liveness
        ),
    }
    lag = StepLag()
    trace: VehicleTrace | None = None
    node: MeshNode | ZenohNode
    if args.transport == "zenoh":
        opened = await _open_zenoh(args, credentials, tag, timing, stop)
        if opened is None:
            return 0  # told to stop while it waited for a router
        node = opened
    else:
        node = await start_node(
            args.id,
            listen=args.listen,
            join=[*args.join, *args.connect],
            tag=tag,
            tls=credentials.tls,
            insecure=credentials.insecure,
            secret=credentials.secret,
            **timing,
        )
    status = 0
    try:
        home = layout.point(args.home)
        heading = home_heading(layout, args.home)
        try:
            driver = vehicle_driver(args, spec, Pose(home.x, home.y, heading))
            held = held_task(args)
            agv = vehicle_class(args.vda5050)(
                node,
                layout,
                spec,
                args.home,
                heading_rad=heading,
                config=config,
                **({} if driver is None else {"driver": driver}),
            )
        except (ValueError, OSError) as exc:  # a state file, or a vehicle off the layout
            print(f"{_who(args)}: {exc}", file=sys.stderr)
            return 2
        if held is not None:
            hand_back(agv, held[0], loaded=held[1])
        if timing["interest_radius"] is not None:
            # Scoped: who never heard a vehicle fail learns it from the vehicles that
            # did, whether or not the control process runs (traffic/stale_relay.py).
            StaleRelay(node)
            StaleListener(node, lambda: agv.book)
        HoldListener(node, agv)  # the control's stop: from the observer alone
        SendHomeListener(node, functools.partial(send_home, agv))  # likewise
        ClosedListener(node, agv, layout)  # closed parts of the floor: the same
        serve_space(node, readers=[OBSERVER_ID])  # the dashboard shows its locks
        display = DisplayPublisher(agv, traffic_interval_s=args.introspection_interval)
        display.publish()
        trace = VehicleTrace(agv, args.trace) if args.trace is not None else None
        stands = agv.vehicle.pose()
        _emit(
            "ready",
            id=node.node_id,
            address=node.address,
            home=args.home,
            position=[stands.x, stands.y],
        )

        refused: list[str] = []

        async def drive() -> None:
            nonlocal status
            try:
                await _settle(node, args)
            except AnotherFleet as exc:
                refused.append(str(exc))
                stop.set()
                return
            if driver is not None:
                announce(agv)  # heard by the peers it has now, before it asks for floor
            _emit("driving", peers=node.peers())
            await _drive(agv, display, args, lag, trace, TaskKeeper(args))
            _emit("fault", reason=agv.vehicle.fault)
            status = 3
            stop.set()

        async def twin() -> None:
            await _watch_twin(node, args)
            refused.append(
                f"another process runs as {args.id} (its token has been up past the lease "
                "of a run that died): give each vehicle its own id"
            )
            stop.set()

        async with asyncio.TaskGroup() as tg:
            tasks = [
                tg.create_task(drive()),
                tg.create_task(_watch_stdin(stop)),
                tg.create_task(_watch_parent(stop, parent)),
                tg.create_task(twin()),
            ]
            if vda5050 is not None:
                tasks.append(tg.create_task(bridge_for(agv, vda5050)))
            await stop.wait()
            _emit("stopping")
            for task in tasks:
                task.cancel()
        if refused:
            print(
                f"{_who(args)}: refused by its fleet: this process runs {tag!r} "
                f"({layout.name}); {refused[0]}",
                file=sys.stderr,
            )
            return 2
    finally:
        outside: dict[str, float] = {}
        if trace is not None:
            trace.close()
            outside = {"outside_m": trace.outside_m}
        await node.close()
        _emit("closed", **lag.fields(), **outside)
        for signum in (signal.SIGTERM, signal.SIGINT):
            loop.remove_signal_handler(signum)
            # Already on the way out: a late SIGTERM (the parent sends one after closing
            # our stdin) must not turn a clean exit into death by signal.
            signal.signal(signum, signal.SIG_IGN)
    return status


def _who(args: argparse.Namespace) -> str:
    return f"objectplaces agv {args.id}"


def register(subcommands: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the ``agv`` subcommand to the ``objectplaces`` command line."""
    parser = subcommands.add_parser(
        "agv",
        help="run one vehicle of a fleet, on its own host",
        description="Run one AGV as a node of its fleet: it joins the fleet at --connect, "
        "waits until it hears a peer, then drives the layout's routes and takes tasks.",
    )
    add_agv_arguments(parser, joining=True)
    parser.set_defaults(func=lambda args: _run_checked(args, parser))


def _run_checked(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    if args.interest_radius not in ("auto", "none"):
        try:
            args.interest_radius = POSITIVE(args.interest_radius)
        except argparse.ArgumentTypeError:
            parser.error("--interest-radius must be 'auto', 'none' or a number > 0")
    return _main(args)


def main(argv: list[str] | None = None) -> int:
    """Run the AGV process.

    Args:
        argv: the arguments; ``sys.argv[1:]`` when None.

    Returns:
        The exit status.
    """
    return _main(parse_args(argv))


def _main(args: argparse.Namespace) -> int:
    profile_dir = os.environ.get(PROFILE_ENV)
    profiler = None
    if profile_dir:
        import cProfile

        profiler = cProfile.Profile(time.thread_time)
        profiler.enable()
    try:
        return asyncio.run(run(args, credentials_from_args(args, args.id)))
    except CredentialError as exc:
        print(f"{_who(args)}: {exc}", file=sys.stderr)
        return 2
    except (LocalProtocolError, OSError) as exc:
        print(f"{_who(args)}: {exc}", file=sys.stderr)
        return 1
    finally:
        if profiler is not None and profile_dir:
            profiler.disable()
            profiler.dump_stats(Path(profile_dir) / f"{args.id}.prof")


if __name__ == "__main__":
    sys.exit(main())
