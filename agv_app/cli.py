"""``objectplaces sim``: run a fleet headless in virtual time and report its figures.

Registered as a plugin of the ``objectplaces`` command (entry point group
``objectplaces.commands``, name ``sim``, value ``agv_app.cli:register``). Exit status 1
when any safety figure (collisions, lock overlaps, deadlocks) is not zero.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from agv_app.fleet.blocks import parse_closure
from agv_app.fleet.compiled import compiled_report, run_compiled
from agv_app.fleet.liveness import REST_BEAT_S, rest_beat_argument
from agv_app.fleet.parking import parking_capacity
from agv_app.fleet.sim import TRAFFIC_MODES, Fleet, FleetConfig
from agv_app.layout.elements import LayoutError
from agv_app.layout.generated import generated_warehouse, parse_generated
from agv_app.layout.graph import Layout
from agv_app.layout.json_format import load_any
from agv_app.tasks.admission import CROWDED, LANE_M_PER_OPEN_TASK, carried_tasks
from agv_app.tasks.desk import parse_max_open
from agv_app.tasks.load import DEFAULT_LOAD
from agv_app.vehicle.battery import BatterySpec
from objectplaces.arguments import POSITIVE, number, whole

__all__ = [
    "DEFAULT_AGVS",
    "SAFETY_KEYS",
    "fleet_size",
    "max_open_argument",
    "register",
    "run_sim",
]

SAFETY_KEYS = ("collisions", "lock_overlaps", "deadlocks")
"""Figures that must all be zero for a run to pass."""
DEFAULT_AGVS = 20


def fleet_size(layout: Layout | None, asked: int | None) -> int:
    """The number of AGVs to run: what was asked, within the layout's parking places.

    Raises:
        ValueError: more AGVs were asked for than the layout has parking places.
    """
    capacity = parking_capacity(layout) if layout is not None else 0
    if asked is None:
        size = min(DEFAULT_AGVS, capacity) if capacity else DEFAULT_AGVS
        if size < DEFAULT_AGVS and layout is not None:
            print(
                f"objectplaces sim: layout {layout.name!r} has {capacity} parking places; "
                f"running {size} AGVs",
                file=sys.stderr,
            )
        return size
    if layout is not None and capacity and asked > capacity:
        raise ValueError(
            f"layout {layout.name!r} has {capacity} parking places, too few for {asked} AGVs: "
            f"the others would rest on its lanes and block them; use --agvs {capacity} or "
            "fewer, or add parking stations"
        )
    return asked


def max_open_argument(text: str) -> int | str | None:
    """``--max-open-tasks``: :func:`~agv_app.tasks.desk.parse_max_open`, for argparse."""
    try:
        return parse_max_open(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def register(subcommands: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the ``sim`` subcommand to the ``objectplaces`` command line."""
    p = subcommands.add_parser(
        "sim",
        help="simulate an AGV fleet headless and report its metrics",
        description=(
            "Run a fleet of AGVs on the simulated network in virtual time, check safety "
            "at every step, and print (and optionally write) the metrics."
        ),
    )
    p.add_argument(
        "--agvs",
        type=whole(at_least=1),
        help=f"number of AGVs (default: {DEFAULT_AGVS}, or fewer if the layout has fewer "
        "parking places)",
    )
    p.add_argument("--minutes", type=POSITIVE, default=60.0, help="simulated minutes")
    p.add_argument("--seed", type=int, default=1, help="random seed")
    p.add_argument(
        "--layout",
        help="layout file (.json or openTCS .xml), or generated:N for a large warehouse "
        "with room for N AGVs; default: demo",
    )
    p.add_argument(
        "--delay", type=number(at_least=0), default=5.0, help="one-way network delay, ms"
    )
    p.add_argument(
        "--loss", type=number(at_least=0, below=1), default=0.0, help="frame loss probability"
    )
    p.add_argument(
        "--broadcast", action="store_true", help="vote with every AGV (no collision groups)"
    )
    p.add_argument(
        "--traffic",
        choices=TRAFFIC_MODES,
        default="protocol",
        help="who grants locks: the AGVs' collision groups (protocol) or one central "
        "first-come-first-served scheduler with no network (central, the baseline)",
    )
    p.add_argument(
        "--load",
        type=number(above=0, at_most=1),
        default=DEFAULT_LOAD,
        help="target share of what the AGVs and the floor carry, in (0, 1]; the task rate "
        "follows from it, the fleet and the layout's stations and two-way stretches "
        f"(default: {DEFAULT_LOAD})",
    )
    p.add_argument(
        "--task-interval",
        type=POSITIVE,
        help="mean seconds between new tasks (overrides --load's rate, no tasks at the start)",
    )
    p.add_argument(
        "--max-open-tasks",
        type=max_open_argument,
        default=CROWDED,
        help="tasks on the floor at once, at most; newer ones wait at the task desk, oldest "
        "first; 'auto': a limit that starts at what the floor's lanes carry, is cut at "
        "every wait over a minute and grows while the floor delivers; 'none': no limit; "
        "'crowded' (default): auto for a fleet larger than its floor carries, else none",
    )
    p.add_argument(
        "--wait-limit",
        type=POSITIVE,
        help="the longest wait accepted, seconds: only the largest fleet whose wait bound is "
        "within it takes tasks, the rest stay parked as a reserve (default: every AGV)",
    )
    p.add_argument(
        "--heartbeat",
        type=POSITIVE,
        help="liveness interval (default: the 1 s update interval): a node silent this long "
        "sends a beat of a few bytes, every property is republished every 600; a node "
        "unheard for three heartbeats counts as failed",
    )
    p.add_argument(
        "--rest-beat",
        type=rest_beat_argument,
        default=REST_BEAT_S,
        help=f"an AGV parked at home with no task, the transport base and the observer beat only "
        f"this often (default {REST_BEAT_S:g} s, or the heartbeat when longer; 'none': as "
        "often as the others); a node at rest counts as failed after three of these",
    )
    p.add_argument(
        "--batteries",
        action="store_true",
        help="give every AGV a battery (BatterySpec's defaults): it drains as it drives and "
        "handles loads, charges at the layout's chargers, and stops if it runs empty "
        '(docs/cli.md, "Batteries")',
    )
    p.add_argument(
        "--close",
        action="append",
        default=[],
        type=parse_closure,
        metavar="KIND:WHAT",
        help="close part of the floor from the start: segment:ID, point:ID or "
        "polygon:X,Y;X,Y;X,Y (repeatable; one that cuts a station off is refused)",
    )
    p.add_argument("--json", dest="json_path", help="write the metrics to this JSON file")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument(
        "--compiled",
        action="store_true",
        help="run on the simulation's modules compiled with mypyc: the same run, faster; "
        "the first run for a source compiles them (a minute or two, needs a C compiler)",
    )
    p.set_defaults(func=run_sim)


def run_sim(args: argparse.Namespace) -> int:
    """Run ``objectplaces sim``.

    Returns:
        0 if every safety figure is zero, 1 if not, 2 on bad arguments or layout.
    """
    if isinstance(args.max_open_tasks, int) and args.max_open_tasks < 1:
        print(
            f"objectplaces sim: --max-open-tasks must be at least 1; got {args.max_open_tasks}",
            file=sys.stderr,
        )
        return 2
    if args.compiled:
        report = compiled_report()
        if report is None:
            return run_compiled(args.command_line)
        print(f"objectplaces sim: {report}", file=sys.stderr)
    try:
        generated = parse_generated(args.layout) if args.layout else None
        layout = generated_warehouse(generated) if generated else None
        layout = layout or (load_any(args.layout) if args.layout else None)
        args.agvs = fleet_size(layout, args.agvs)
        config = FleetConfig(
            agvs=args.agvs,
            seed=args.seed,
            delay=args.delay / 1000,
            jitter=args.delay / 2000,
            loss=args.loss,
            broadcast=args.broadcast,
            traffic=args.traffic,
            load=args.load,
            task_interval=args.task_interval,
            max_open_tasks=args.max_open_tasks,
            heartbeat=args.heartbeat,
            rest_beat=args.rest_beat,
            batteries=BatterySpec() if args.batteries else None,
            wait_limit=args.wait_limit,
        )
        fleet = Fleet(layout, config)
        for kind, what in args.close:
            fleet.blocks.close(kind, what, reason="--close", by="the command line")
    except (LayoutError, ValueError, OSError) as exc:
        print(f"objectplaces sim: {exc}", file=sys.stderr)
        return 2
    if fleet.active < args.agvs:
        print(
            f"objectplaces sim: --wait-limit {args.wait_limit:g}: {fleet.active} of {args.agvs} "
            f"AGVs take tasks, the rest stay parked as a reserve (wait bound "
            f"{fleet.wait_bound.seconds:.1f} s)",
            file=sys.stderr,
        )
    seconds = args.minutes * 60
    started = time.perf_counter()
    if args.quiet:
        fleet.run(seconds)
    else:
        from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

        with Progress(
            TextColumn("[bold]sim[/] {task.description}"),
            BarColumn(),
            TextColumn("{task.completed:.0f}/{task.total:.0f} s"),
            TimeElapsedColumn(),
            transient=True,
        ) as progress:
            bar = progress.add_task(f"{args.agvs} AGVs", total=seconds)
            fleet.run(seconds, lambda now: progress.update(bar, completed=now))
    figures = fleet.summary(time.perf_counter() - started)
    width = max(len(k) for k in figures)
    for key, value in figures.items():
        # The bound with the terms it is made of, read off the layout and the fleet.
        shown = fleet.wait_bound if key == "wait_bound" else value
        print(f"{key:<{width}}  {shown}")
    admission = fleet.desk.admission
    if admission is not None:
        print(
            f"{'open_tasks_limit':<{width}}  {admission.limit} at the end (auto: lowest "
            f"{admission.lowest}, {admission.cuts} cuts)"
        )
    for violation in fleet.monitor.violations:
        print(f"VIOLATION {violation}", file=sys.stderr)
    if figures["max_wait"] > figures["wait_bound"]:
        print(
            f"objectplaces sim: a wait of {figures['max_wait']:g} s passed the wait bound of "
            f"{figures['wait_bound']:g} s: this run breaks an assumption of the bound "
            '(docs/traffic.md, "Bounded waits")',
            file=sys.stderr,
        )
    if figures["deadlocks"] and fleet.desk.admission is None and fleet.desk.max_open is None:
        carried = carried_tasks(fleet.layout)
        per = f"one per {LANE_M_PER_OPEN_TASK:g} m of lane"
        about = "" if carried is None else f"; this floor carries about {carried} ({per})"
        print(
            f"objectplaces sim: {figures['deadlocks']:.0f} waits passed "
            f"{fleet.stalls.limit_s:.0f} s. A fleet larger than its floor carries fills the "
            "lanes: --max-open-tasks K keeps K tasks on the floor and the rest at the task "
            f"desk{about}; --max-open-tasks auto finds the number as the fleet runs "
            '(docs/fleet.md, "More AGVs than the floor carries")',
            file=sys.stderr,
        )
    if args.json_path:
        Path(args.json_path).write_text(json.dumps(figures, indent=2, sort_keys=True) + "\n")
    if fleet.chargers is not None:
        for at, agv_id, alarm in fleet.chargers.alarms:
            print(f"ALARM {at:.1f} s {agv_id}: {alarm}", file=sys.stderr)
    ran_empty = figures.get("ran_empty", 0)
    return 1 if ran_empty or any(figures[k] for k in SAFETY_KEYS) else 0
