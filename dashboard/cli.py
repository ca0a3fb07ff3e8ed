"""``objectplaces demo``: a fleet in real time with its dashboard.

Registered as a plugin of the ``objectplaces`` command (entry point group
``objectplaces.commands``, name ``demo``, value ``dashboard.cli:register``).
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import ipaddress
import os
import sys
import threading
import webbrowser
from collections.abc import Callable
from typing import TYPE_CHECKING

from objectplaces.arguments import number, whole

if TYPE_CHECKING:
    from dashboard.source import FleetSource

__all__ = [
    "TOKEN_ENV",
    "build_source",
    "is_loopback",
    "register",
    "run_demo",
    "serve",
]

TOKEN_ENV = "OBJECTPLACES_TOKEN"
"""Environment variable read when ``--token`` is not given."""

SourceBuilder = Callable[[argparse.Namespace], "FleetSource"]


def is_loopback(host: str) -> bool:
    """True when ``host`` only accepts connections from this machine."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def _max_open_tasks(text: str) -> int | str | None:
    """``--max-open-tasks``: a whole number or ``auto``, read as ``objectplaces sim``
    reads it."""
    return importlib.import_module("agv_app.cli").max_open_argument(text)  # type: ignore[no-any-return]


def register(subcommands: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the ``demo`` subcommand to the ``objectplaces`` command line."""
    parser = subcommands.add_parser(
        "demo",
        help="run an AGV fleet in real time with its live dashboard",
        description=(
            "Run a fleet of AGVs on the demo warehouse in real time, with tasks arriving "
            "continuously, and serve the dashboard (REST API, live feed, page)."
        ),
    )
    parser.add_argument("--host", default="127.0.0.1", help="address to listen on")
    parser.add_argument(
        "--port", type=whole(at_least=0, at_most=65535), default=8000, help="port to listen on"
    )
    parser.add_argument(
        "--agvs",
        type=whole(at_least=1),
        default=None,
        help="number of AGVs of one simulated fleet (default 12); not with --processes",
    )
    parser.add_argument("--seed", type=int, default=1, help="random seed of the fleet")
    parser.add_argument(
        "--load",
        type=number(above=0, at_most=1),
        default=None,
        help="share of AGVs kept busy, in (0, 1]; the task rate follows from the layout "
        "(default: the fleet's, 0.7)",
    )
    parser.add_argument(
        "--max-open-tasks",
        type=_max_open_tasks,
        default="crowded",  # agv_app.tasks.admission.CROWDED
        help="tasks on the floor at once, at most; newer ones wait at the task desk, oldest "
        "first; 'auto': a limit that follows the floor's long waits; 'none': no limit; "
        "'crowded' (default): auto for a fleet larger than its floor carries, else none",
    )
    parser.add_argument(
        "--processes",
        type=whole(at_least=0),
        default=0,
        help="run every AGV as its own process on the WebSocket mesh (this many AGVs and "
        "processes); not with --agvs",
    )
    parser.add_argument(
        "--transport",
        choices=["websocket", "zenoh"],
        default="websocket",
        help="how the AGV processes talk (with --processes): the WebSocket mesh or Zenoh",
    )
    parser.add_argument(
        "--vda5050",
        nargs="?",
        const="local",
        default=None,
        metavar="mqtt://HOST:PORT",
        help="every AGV speaks VDA 5050 over this MQTT broker, with --processes from its own "
        "process (the flag alone: a mosquitto started on 127.0.0.1 for the demo); no "
        "automatic tasks",
    )
    parser.add_argument(
        "--token",
        default=os.environ.get(TOKEN_ENV),
        help=f"token for changes (POST/DELETE); required off loopback (env {TOKEN_ENV})",
    )
    parser.add_argument("--open", action="store_true", help="open the dashboard in a browser")
    parser.set_defaults(func=run_demo)


def build_source(args: argparse.Namespace) -> FleetSource:
    """Build the fleet the demo shows.

    Raises:
        SystemExit: the fleet simulation is not installed.
    """
    try:
        fleet = importlib.import_module("agv_app.fleet")
    except ImportError as exc:
        raise SystemExit(f"objectplaces demo: the AGV fleet is not available ({exc})") from exc
    make: Callable[..., FleetSource] | None = getattr(fleet, "demo_source", None)
    if make is None:
        raise SystemExit("objectplaces demo: agv_app.fleet offers no demo_source()")
    try:
        # --agvs left out (None): the demo fleet's own default.
        vda5050 = getattr(args, "vda5050", None)
        extra: dict[str, str] = {} if vda5050 is None else {"vda5050": vda5050}
        if getattr(args, "transport", "websocket") != "websocket":
            extra["transport"] = args.transport
        limit = getattr(args, "max_open_tasks", "crowded")
        extra_limit: dict[str, int | str | None] = {"max_open_tasks": limit}
        return make(
            agvs=args.agvs,
            seed=args.seed,
            processes=args.processes,
            load=args.load,
            **extra,
            **extra_limit,
        )
    except ValueError as exc:
        raise SystemExit(f"objectplaces demo: {exc}") from exc


def serve(
    source: FleetSource,
    *,
    host: str,
    port: int,
    token: str | None,
    open_browser: bool = False,
) -> None:
    """Serve the dashboard for ``source`` until interrupted.

    Raises:
        SystemExit: a non-loopback host without a token.
    """
    import uvicorn

    from dashboard.app import create_app

    if token is None and not is_loopback(host):
        raise SystemExit(
            f"objectplaces demo: listening on {host!r} lets other machines in; "
            f"give --token (or set {TOKEN_ENV}) so only you can change the fleet"
        )
    app = create_app(source, token=token)
    shown = "127.0.0.1" if host in ("0.0.0.0", "::") else host
    url = f"http://{shown}:{port}/" + (f"?token={token}" if token else "")
    print(f"dashboard at {url}", flush=True)
    if open_browser:
        threading.Timer(1.0, webbrowser.open, args=(url,)).start()
    uvicorn.run(app, host=host, port=port, log_level="warning")


def run_demo(args: argparse.Namespace, *, builder: SourceBuilder = build_source) -> int:
    """Run ``objectplaces demo``.

    Returns:
        The exit status.
    """
    if args.agvs is not None and args.processes:
        print(
            f"objectplaces demo: give --agvs {args.agvs} (one simulated fleet) or "
            f"--processes {args.processes} (one process per AGV), not both",
            file=sys.stderr,
        )
        return 2
    limit = getattr(args, "max_open_tasks", None)
    if isinstance(limit, int) and limit < 1:
        print(
            f"objectplaces demo: --max-open-tasks must be at least 1, got {limit}", file=sys.stderr
        )
        return 2
    if args.token is None and not is_loopback(args.host):
        print(
            f"objectplaces demo: listening on {args.host!r} lets other machines in; "
            f"give --token (or set {TOKEN_ENV}) so only you can change the fleet",
            file=sys.stderr,
        )
        return 2
    from agv_app.vda5050.broker import demo_broker

    with contextlib.ExitStack() as stack:
        try:
            args.vda5050 = stack.enter_context(demo_broker(getattr(args, "vda5050", None)))
        except (ValueError, OSError, RuntimeError) as exc:
            print(f"objectplaces demo: --vda5050: {exc}", file=sys.stderr)
            return 2
        if args.vda5050 is not None:
            print(f"VDA 5050 over {args.vda5050}", flush=True)
        source = builder(args)
        serve(source, host=args.host, port=args.port, token=args.token, open_browser=args.open)
    return 0
