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
``battery`` (with ``--battery``: its state of charge, percent; it charges as the
control grants, :mod:`agv_app.fleet.charge_listener`), ``size``
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

This module runs the process (:func:`run`, :func:`main`); its parts are the command
line (:mod:`~agv_app.fleet.agv_args`), joining the fleet
(:mod:`~agv_app.fleet.agv_joining`), the run loop (:mod:`~agv_app.fleet.agv_drive`),
what it shows the observer (:mod:`~agv_app.fleet.agv_display`), what else stops it
(:mod:`~agv_app.fleet.agv_watch`) and what it prints (:mod:`~agv_app.fleet.agv_events`).
"""

from __future__ import annotations

import argparse
import asyncio
import functools
import os
import signal
import sys
import time
from pathlib import Path
from typing import Any

from agv_app.fleet.agv_args import (
    POLL_INTERVAL_S,
    add_agv_arguments,
    build_parser,
    check_interest_radius,
    dissemination_radius,
    parse_args,
    process_liveness,
)
from agv_app.fleet.agv_display import DisplayPublisher
from agv_app.fleet.agv_drive import StepLag, drive_steps
from agv_app.fleet.agv_events import emit, who
from agv_app.fleet.agv_joining import AnotherFleet, open_zenoh, settle
from agv_app.fleet.agv_watch import watch_parent, watch_stdin, watch_twin
from agv_app.fleet.charge_listener import ChargeListener, ServiceGate
from agv_app.fleet.closed_listener import ClosedListener
from agv_app.fleet.holding import HoldListener
from agv_app.fleet.liveness import liveness_arguments
from agv_app.fleet.parking import home_heading
from agv_app.fleet.restart_state import TaskKeeper, held_task, vehicle_driver
from agv_app.fleet.sending_home import SendHomeListener
from agv_app.fleet.trace import VehicleTrace
from agv_app.fleet.view import OBSERVER_ID
from agv_app.geometry import Pose
from agv_app.layout.choice import layout_digest, layout_from_argument
from agv_app.layout.demo import DEMO_VEHICLE_LENGTH_M, DEMO_VEHICLE_WIDTH_M
from agv_app.layout.elements import LayoutError
from agv_app.traffic.stale_relay import StaleListener, StaleRelay
from agv_app.vda5050.link import BrokerError, MqttLink, check_broker
from agv_app.vda5050.process import bridge_for, vehicle_class, vehicle_link
from agv_app.vehicle.comeback import announce, hand_back
from agv_app.vehicle.controller import AgvConfig
from agv_app.vehicle.kinematics import VehicleSpec
from agv_app.vehicle.service import send_home
from objectplaces.core.errors import LocalProtocolError
from objectplaces.mesh import MeshNode, start_node
from objectplaces.security import CredentialError, Credentials, credentials_from_args
from objectplaces.space_pages import serve_space
from objectplaces.zenoh_node import ZenohNode

__all__ = [
    "POLL_INTERVAL_S",
    "PROFILE_ENV",
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

PROFILE_ENV = "OBJECTPLACES_AGV_PROFILE"
"""A directory: each AGV process profiles its event loop's thread (cProfile, in thread
CPU time) and writes ``<id>.prof`` there when it stops. Off by default."""


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
        print(f"{who(args)}: --layout: {exc}", file=sys.stderr)
        return 2
    if args.home not in layout.points:
        print(
            f"{who(args)}: --home {args.home!r} is no point of layout {layout.name!r}",
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
            print(f"{who(args)}: --vda5050: {exc}", file=sys.stderr)
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
        battery=args.battery_spec if args.battery else None,
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
        opened = await open_zenoh(args, credentials, tag, timing, stop)
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
            print(f"{who(args)}: {exc}", file=sys.stderr)
            return 2
        if held is not None:
            hand_back(agv, held[0], loaded=held[1])
        if timing["interest_radius"] is not None:
            # Scoped: who never heard a vehicle fail learns it from the vehicles that
            # did, whether or not the control process runs (traffic/stale_relay.py).
            StaleRelay(node)
            StaleListener(node, lambda: agv.book)
        gate = ServiceGate(agv)  # the battery's word on top of the operator's
        HoldListener(node, gate)  # the control's stop: from the observer alone
        charging = ChargeListener(node, agv, gate) if args.battery else None  # likewise
        SendHomeListener(node, functools.partial(send_home, agv))  # likewise
        ClosedListener(node, agv, layout)  # closed parts of the floor: the same
        serve_space(node, readers=[OBSERVER_ID])  # the dashboard shows its locks
        display = DisplayPublisher(
            agv,
            traffic_interval_s=args.introspection_interval,
            shown=None if charging is None else charging.status,
        )
        display.publish()
        trace = VehicleTrace(agv, args.trace) if args.trace is not None else None
        stands = agv.vehicle.pose()
        emit(
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
                await settle(node, args)
            except AnotherFleet as exc:
                refused.append(str(exc))
                stop.set()
                return
            if driver is not None:
                announce(agv)  # heard by the peers it has now, before it asks for floor
            emit("driving", peers=node.peers())
            battery = None if charging is None else charging.step
            await drive_steps(agv, display, args, lag, trace, TaskKeeper(args), battery)
            emit("fault", reason=agv.vehicle.fault)
            status = 3
            stop.set()

        async def twin() -> None:
            await watch_twin(node, args)
            refused.append(
                f"another process runs as {args.id} (its token has been up past the lease "
                "of a run that died): give each vehicle its own id"
            )
            stop.set()

        async with asyncio.TaskGroup() as tg:
            tasks = [
                tg.create_task(drive()),
                tg.create_task(watch_stdin(stop)),
                tg.create_task(watch_parent(stop, parent)),
                tg.create_task(twin()),
            ]
            if vda5050 is not None:
                tasks.append(tg.create_task(bridge_for(agv, vda5050)))
            await stop.wait()
            emit("stopping")
            for task in tasks:
                task.cancel()
        if refused:
            print(
                f"{who(args)}: refused by its fleet: this process runs {tag!r} "
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
        emit("closed", **lag.fields(), **outside)
        for signum in (signal.SIGTERM, signal.SIGINT):
            loop.remove_signal_handler(signum)
            # Already on the way out: a late SIGTERM (the parent sends one after closing
            # our stdin) must not turn a clean exit into death by signal.
            signal.signal(signum, signal.SIG_IGN)
    return status


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
    check_interest_radius(args, parser)
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
        print(f"{who(args)}: {exc}", file=sys.stderr)
        return 2
    except (LocalProtocolError, OSError) as exc:
        print(f"{who(args)}: {exc}", file=sys.stderr)
        return 1
    finally:
        if profiler is not None and profile_dir:
            profiler.disable()
            profiler.dump_stats(Path(profile_dir) / f"{args.id}.prof")


if __name__ == "__main__":
    sys.exit(main())
