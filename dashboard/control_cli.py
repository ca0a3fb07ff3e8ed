"""``objectplaces control``: the transport base, the task desk, the observer and the
dashboard of a fleet whose vehicles run elsewhere.

```sh
objectplaces control --layout plant.json --pki fleet-pki \\
    --connect 10.0.0.2:7001 --listen 10.0.0.1:7001 --agvs 20 --load 0.7
objectplaces control --transport zenoh --pki fleet-pki \\
    --connect tls/10.0.0.2:7447 --connect tls/10.0.0.3:7447
```

It joins the fleet at ``--connect`` (nodes of the mesh, or Zenoh routers) as two nodes,
``observer`` and ``base``, with their certificates in the PKI folder, keeps the
transport orders and the event log in an SQLite order book (``--db``: a control killed
and started again takes up every open order, none twice; ``docs/fleet.md``), and serves
the dashboard (``dashboard.listen``: a token always, TLS off loopback, with the PKI's
``control`` certificate). Registered as a plugin of the ``objectplaces`` command.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from dashboard.cli import serve
from dashboard.listen import add_listen_arguments, listening_from_args
from objectplaces.arguments import number, whole
from objectplaces.core.errors import LocalProtocolError
from objectplaces.security import CredentialError, Identity

__all__ = ["register", "run_control"]


def register(subcommands: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the ``control`` subcommand to the ``objectplaces`` command line."""
    parser = subcommands.add_parser(
        "control",
        help="the task desk, the observer and the dashboard of a fleet running elsewhere",
        description="Join a fleet whose vehicles run on other hosts (objectplaces agv) as "
        "its transport base and observer, and serve its dashboard.",
    )
    parser.add_argument(
        "--layout",
        help="the fleet's layout: a .json or openTCS .xml file, generated:N, or demo "
        "(default: the demo warehouse); every vehicle must run the same",
    )
    parser.add_argument(
        "--connect",
        action="append",
        default=[],
        required=True,
        metavar="ENDPOINT",
        help="where the fleet is: a node of the mesh (HOST:PORT) or a Zenoh router "
        "(tls/HOST:PORT); repeatable",
    )
    parser.add_argument(
        "--transport", choices=["websocket", "zenoh"], default="websocket", help="how nodes talk"
    )
    parser.add_argument(
        "--listen",
        default="127.0.0.1:0",
        metavar="HOST:PORT",
        help="the mesh: where the observer listens (vehicles may join through it)",
    )
    parser.add_argument(
        "--port", type=whole(at_least=0, at_most=65535), default=8000, help="dashboard port"
    )
    parser.add_argument(
        "--agvs",
        type=whole(at_least=1),
        default=1,
        help="vehicles to hear before the first automatic task (and for the task rate)",
    )
    parser.add_argument(
        "--load",
        type=number(above=0, at_most=1),
        default=None,
        help="share of what the vehicles and the floor carry that automatic tasks use, in "
        "(0, 1] (default: no "
        "automatic tasks: orders come from the dashboard, the REST API or a master control)",
    )
    parser.add_argument("--seed", type=int, default=1, help="seeds the automatic tasks")
    parser.add_argument(
        "--t-update", type=number(above=0), default=1.0, help="property interval, s (as the AGVs')"
    )
    parser.add_argument(
        "--db",
        type=Path,
        default=Path("orders.sqlite"),
        help="the order book: transport orders, their states and the event log (SQLite; "
        "made if missing; one control at a time; default: orders.sqlite)",
    )
    add_listen_arguments(parser)
    parser.set_defaults(func=run_control)


def run_control(args: argparse.Namespace) -> int:
    """Run ``objectplaces control``; 2 when an argument, a credential or the layout
    cannot be used."""
    from agv_app.fleet.mesh import Joining, MeshFleet
    from agv_app.fleet.view import OBSERVER_ID
    from agv_app.layout.choice import layout_from_argument
    from agv_app.layout.demo import DEMO_VEHICLE_LENGTH_M
    from agv_app.layout.elements import LayoutError
    from agv_app.tasks import OrderStore, StoreError
    from agv_app.tasks.desk import BASE_ID
    from agv_app.tasks.load import fleet_floor_rules, task_interval_for_load
    from agv_app.vehicle.config import AgvConfig
    from agv_app.vehicle.kinematics import VehicleSpec
    from dashboard.eventlog import EventLog

    if args.pki is None:
        print(
            "objectplaces control: give --pki DIR: its nodes join the fleet with the "
            "certificates DIR/observer.pem and DIR/base.pem",
            file=sys.stderr,
        )
        return 2
    try:
        for node_id in (OBSERVER_ID, BASE_ID):  # checked now: refused before serving
            Identity.from_pki(args.pki, node_id)
        layout = layout_from_argument(args.layout)
        listening = listening_from_args(args, args.port)
    except (LayoutError, ValueError, OSError) as exc:
        print(f"objectplaces control: --layout: {exc}", file=sys.stderr)
        return 2
    except CredentialError as exc:
        print(f"objectplaces control: {exc}", file=sys.stderr)
        return 2
    interval = None
    if args.load is not None:
        spec = VehicleSpec(DEMO_VEHICLE_LENGTH_M, 1.0)
        interval = task_interval_for_load(
            layout,
            agvs=args.agvs,
            load=args.load,
            speed_m_s=spec.max_speed_m_s,
            dwell_s=5.0,
            rules=fleet_floor_rules(spec, t_update=AgvConfig().t_update),
        )
    try:
        store = OrderStore.open(args.db)
    except StoreError as exc:
        print(f"objectplaces control: {exc}", file=sys.stderr)
        return 2
    try:
        fleet = MeshFleet(
            agvs=args.agvs,
            seed=args.seed,
            layout=layout,
            task_interval=interval if interval is not None and math.isfinite(interval) else None,
            t_update=args.t_update,
            transport=args.transport,
            joining=Joining(
                connect=tuple(args.connect),
                listen=args.listen,
                pki=args.pki,
                layout_argument=args.layout,
            ),
            store=store,
        )
        events = EventLog(store=store)  # after the desk: it gives the store the clock
    except (ValueError, LocalProtocolError) as exc:
        store.close()
        print(f"objectplaces control: {exc}", file=sys.stderr)
        return 2
    try:
        serve(fleet, listening=listening, events=events)
    finally:
        store.close()
    return 0
