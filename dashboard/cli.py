"""``objectplaces demo``: a fleet in real time with its dashboard.

Registered as a plugin of the ``objectplaces`` command (entry point group
``objectplaces.commands``, name ``demo``, value ``dashboard.cli:register``). Who may use
the dashboard and how it is reached (tokens, TLS, host names): ``dashboard.listen``.
"""

from __future__ import annotations

import argparse
import contextlib
import html
import importlib
import shutil
import sys
import tempfile
import threading
import webbrowser
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from dashboard.listen import Listening, add_listen_arguments, listening_from_args, login_url
from objectplaces.arguments import number, whole
from objectplaces.core.errors import LocalProtocolError
from objectplaces.security import CredentialError
from objectplaces.security.pki import write_private

if TYPE_CHECKING:
    from dashboard.eventlog import EventLog
    from dashboard.source import FleetSource

__all__ = ["build_source", "register", "run_demo", "serve"]

SourceBuilder = Callable[[argparse.Namespace], "FleetSource"]


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
        help="share of what the AGVs and the floor carry, in (0, 1]; the task rate follows "
        "from the fleet and the layout (default: the fleet's, 0.7)",
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
        metavar="mqtts://HOST:PORT",
        help="every AGV speaks VDA 5050 over this MQTT broker with its certificate of "
        "--pki DIR (mqtt:// only with --insecure, on loopback), with --processes from its "
        "own process (the flag alone: a mosquitto with a throwaway fleet PKI on 127.0.0.1 "
        "for the demo); no automatic tasks",
    )
    parser.add_argument("--open", action="store_true", help="open the dashboard in a browser")
    add_listen_arguments(parser)
    parser.add_argument(
        "--insecure",
        action="store_true",
        help="with --vda5050: a plain MQTT link (mqtt://), on loopback only",
    )
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
        extra: dict[str, object] = {} if vda5050 is None else {"vda5050": vda5050}
        if vda5050 is not None:
            extra["vda5050_credentials"] = getattr(args, "vda5050_credentials", None)
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
    except LocalProtocolError as exc:  # a certificate that cannot be used, named
        print(f"objectplaces demo: {exc}", file=sys.stderr)
        raise SystemExit(2) from None


def serve(
    source: FleetSource,
    *,
    listening: Listening,
    open_browser: bool = False,
    events: EventLog | None = None,
) -> None:
    """Serve the dashboard for ``source`` until interrupted (``events``: the operator's
    log, kept on the control's order store).

    Prints the login URLs once, on standard output (never on a command line: a browser
    opened with ``open_browser`` is given a private file that leads there).
    """
    import uvicorn

    from dashboard.app import create_app

    app = create_app(source, tokens=listening.tokens, hosts=listening.hosts, events=events)
    if listening.token_file is not None:
        made = "made now, " if listening.created else ""
        print(f"tokens in {listening.token_file} ({made}mode 0600)", flush=True)
    operator = login_url(listening, "operator")
    print(
        f"dashboard at {operator.partition('/login')[0]}/, log in with one of these "
        f"(each holds a token: share it only with whom it is for):\n"
        f"  operator (reads and changes): {operator}\n"
        f"  viewer (reads):               {login_url(listening, 'viewer')}",
        flush=True,
    )
    cert, key = listening.tls if listening.tls else (None, None)
    with contextlib.ExitStack() as stack:
        if open_browser:
            _open_privately(operator, stack)
        uvicorn.run(
            app,
            host=listening.host,
            port=listening.port,
            log_level="warning",
            ssl_certfile=cert,
            ssl_keyfile=key,
        )


def _open_privately(url: str, stack: contextlib.ExitStack) -> None:
    # A browser started with the URL would show the token in `ps` for as long as it
    # runs: it opens a file only we can read, which sends it on, instead.
    folder = Path(tempfile.mkdtemp(prefix="objectplaces-login-"))
    stack.callback(shutil.rmtree, folder, ignore_errors=True)
    page = folder / "login.html"
    target = html.escape(url, quote=True)
    write_private(
        page,
        f'<!doctype html><meta charset="utf-8"><meta name="referrer" content="no-referrer">'
        f'<meta http-equiv="refresh" content="0;url={target}">'
        f'<a href="{target}">open the dashboard</a>\n'.encode(),
    )
    threading.Timer(1.0, webbrowser.open, args=(page.as_uri(),)).start()


def run_demo(args: argparse.Namespace, *, builder: SourceBuilder = build_source) -> int:
    """Run ``objectplaces demo``.

    Returns:
        The exit status: 2 for arguments, credentials or files that cannot be used.
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
    try:
        listening = listening_from_args(args, args.port)
    except CredentialError as exc:
        print(f"objectplaces demo: {exc}", file=sys.stderr)
        return 2
    from agv_app.vda5050.demo import demo_vda5050

    with contextlib.ExitStack() as stack:
        try:
            vda5050 = stack.enter_context(demo_vda5050(args))
        except (ValueError, OSError, RuntimeError, LocalProtocolError) as exc:
            print(f"objectplaces demo: --vda5050: {exc}", file=sys.stderr)
            return 2
        if vda5050 is not None:
            args.vda5050, args.vda5050_credentials = vda5050.url, vda5050.credentials
            print(vda5050.describe(), flush=True)
        source = builder(args)
        serve(source, listening=listening, open_browser=args.open)
    return 0
