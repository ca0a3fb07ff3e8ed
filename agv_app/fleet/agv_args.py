"""The command line of an AGV process (:mod:`agv_app.fleet.agv_process`), and what its
numbers make of the node: its liveness and its interest radius.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from agv_app.fleet.agv_drive import MAX_LAG_S
from agv_app.fleet.liveness import (
    REPUBLISH_BEATS,
    REST_BEAT_S,
    fleet_liveness,
    rest_beat_argument,
)
from agv_app.fleet.restart_state import add_driver_arguments
from agv_app.layout.graph import Layout
from agv_app.traffic.reach import interest_radius
from agv_app.vehicle.battery import BatterySpec
from agv_app.vehicle.controller import AgvConfig
from agv_app.vehicle.kinematics import VehicleSpec
from objectplaces.arguments import POSITIVE, number, whole
from objectplaces.core.config import NodeConfig
from objectplaces.security import add_credential_arguments

__all__ = [
    "POLL_INTERVAL_S",
    "add_agv_arguments",
    "battery_spec",
    "build_parser",
    "check_interest_radius",
    "dissemination_radius",
    "parse_args",
    "process_liveness",
]

POLL_INTERVAL_S = 0.05
"""On Zenoh, received frames are handed to the node together every this many seconds
(half the control step): one wake-up for several frames instead of two each. Ten AGV
processes beside ten others, same run: 27.7 ms of CPU a second each against 31.5 with
0.025 s. The frames wait up to this long, well inside the second of delay the interest
radius allows for (``MAX_LAG_S``)."""


def battery_spec(text: str) -> BatterySpec:
    """``--battery-spec``: a :class:`~agv_app.vehicle.battery.BatterySpec` from a JSON
    object of its fields.

    Raises:
        argparse.ArgumentTypeError: not JSON, not an object, or not a valid spec.
    """
    try:
        fields = json.loads(text)
        if not isinstance(fields, dict):
            raise ValueError("not a JSON object")
        return BatterySpec(**fields)
    except (ValueError, TypeError) as exc:
        raise argparse.ArgumentTypeError(f"not a battery spec: {exc}") from None


def process_liveness(
    t_update: float, republish_beats: int = REPUBLISH_BEATS, rest_beat: float | None = REST_BEAT_S
) -> NodeConfig:
    """Liveness by beats, as the simulated fleet runs it (``fleet_liveness``): a beat of a
    few bytes after ``t_update`` without a publication, every ``rest_beat`` while parked
    idle, every property again only every ``republish_beats`` beats (0: no beats, every
    property republished each ``t_update``)."""
    republish = republish_beats * t_update if republish_beats > 0 else None
    return fleet_liveness(t_update, republish=republish, rest_beat=rest_beat)


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
    radius = interest_radius(layout, spec, config, delay_s=MAX_LAG_S, failure_detection_s=detection)
    # Every node on such a floor lies within the radius of every other: scoping would
    # leave nobody out, and one subscription to everything costs a receiver less than a
    # subscriber per row of cells (docs/zenoh.md, "Keys").
    return None if radius >= layout.diagonal() else radius


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
        help="a battery that drains as the vehicle drives and is reported (``battery``, "
        "VDA 5050 powerSupply); it charges on a charger the control grants, and at 0 %% "
        "the vehicle stops (agv_app/fleet/charge_listener.py)",
    )
    parser.add_argument(
        "--battery-spec",
        type=battery_spec,
        default=BatterySpec(),
        help="with --battery, its BatterySpec as a JSON object of fields (default: the defaults)",
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
    check_interest_radius(args, parser)
    return args


def check_interest_radius(args: argparse.Namespace, parser: argparse.ArgumentParser) -> None:
    """Make ``--interest-radius`` a number unless it is ``auto`` or ``none``; anything
    else is a usage error of ``parser`` (it exits)."""
    if args.interest_radius not in ("auto", "none"):
        try:
            args.interest_radius = POSITIVE(args.interest_radius)
        except argparse.ArgumentTypeError:
            parser.error("--interest-radius must be 'auto', 'none' or a number > 0")
