"""A fleet across hosts under network faults, against the same fleet without them.

Run: ``.venv/bin/python bench/netfaults.py`` (``--vehicles 20 --minutes 30 --layout demo``;
``--layout generated:40 --kill-vehicle`` for the large warehouse with a vehicle killed
while the control process is down). Needs root (network namespaces).

Vehicles, two linked Zenoh routers and the control process, each on a host of its own
(tests/hosts/harness.py), over mutual TLS. Two runs of ``--minutes`` at ``--load``:
one without faults, one with every vehicle losing 5 % of what it receives, capped at
256 kbit/s each way and cut off for 5 s every 10 minutes (Wi-Fi roaming), router ``r1``
killed at a third of the run and the control process killed at two thirds (both
started again at once). Figures:

- collisions, lock overlaps and metres driven outside a vehicle's own locked floor,
  from the vehicles' own traces merged after the run (goal: 0, 0, 0);
- how long after its link came back a vehicle that was driving moved again (p99;
  goal <= 3 s);
- tasks done per hour with faults against without (goal >= 80 %).
"""

from __future__ import annotations

import argparse
import json
import math
import signal
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve()
ROOT = HERE.parent.parent
sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != HERE.parent]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from bench.report import markdown_table, publish  # noqa: E402
from tests.hosts.harness import FleetOnHosts  # noqa: E402

LOSS_PERCENT = 5
CAP_KBIT = 256
OUTAGE_S = 5.0
OUTAGE_EVERY_S = 600.0
MOVE_M = 0.01


def _poses(trace: Path) -> list[tuple[float, float, float]]:
    out = []
    for line in trace.read_text().splitlines():
        try:
            record = json.loads(line)
        except ValueError:
            continue
        if record.get("k") == "pose":
            out.append((float(record["t"]), float(record["p"][0]), float(record["p"][1])))
    return sorted(out)


def recovery_times(traces: Path, outages: list[tuple[float, float, str]]) -> list[float]:
    """For each outage ``(down, up, vehicle)`` of a vehicle that was driving when its link
    went down: seconds from the link's return to its next move."""
    found = []
    for down, up, vehicle in outages:
        poses = _poses(traces / f"{vehicle}.jsonl")
        before = [p for p in poses if down - 1.0 <= p[0] <= down]
        driving = len(before) >= 2 and math.dist(before[0][1:], before[-1][1:]) > MOVE_M
        if not driving:
            continue
        at_up = next((p for p in reversed(poses) if p[0] <= up), None)
        after = [p for p in poses if p[0] > up]
        if at_up is None:
            continue
        moved = next((p for p in after if math.dist(p[1:], at_up[1:]) > MOVE_M), None)
        if moved is not None:
            found.append(moved[0] - up)
    return found


def p99(values: list[float]) -> float:
    if not values:
        return math.nan
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, math.ceil(0.99 * len(ordered)) - 1)]


def run(args: argparse.Namespace, *, faults: bool) -> dict[str, Any]:
    seconds = args.minutes * 60.0
    with (
        tempfile.TemporaryDirectory(prefix="netfaults-") as folder,
        FleetOnHosts(
            vehicles=args.vehicles,
            workdir=Path(folder),
            layout=args.layout,
            load=args.load,
            run_seconds=seconds + 300,
        ) as fleet,
    ):
        fleet.start(within=600)
        started = time.monotonic()
        outages: list[tuple[float, float, str]] = []
        if faults:
            for name in fleet.vehicle_ids:
                host = fleet.procs[name].host
                fleet.net.loss(host, LOSS_PERCENT)
                fleet.net.cap(host, CAP_KBIT)
        plan = _fault_plan(fleet.vehicle_ids, seconds, args.kill_vehicle) if faults else []
        threads: list[threading.Thread] = []
        open_at_kill: set[str] = set()
        for at, what, who in plan:
            time.sleep(max(0.0, started + at - time.monotonic()))
            if what == "outage":

                def cut(name: str = who) -> None:
                    down = time.time()
                    fleet.outage(name, OUTAGE_S)
                    outages.append((down, time.time(), name))

                thread = threading.Thread(target=cut)
                thread.start()
                threads.append(thread)
            elif what == "kill":
                if who == "control":
                    open_at_kill = set(fleet.orders())
                fleet.kill(who)
            elif what == "start":
                fleet.restart(who)
            print(f"{time.monotonic() - started:7.1f} s: {what} {who}", file=sys.stderr)
        time.sleep(max(0.0, started + seconds - time.monotonic()))
        for thread in threads:
            thread.join()
        known_at_end = set(fleet.orders())
        report = fleet.stop()
        delivered = fleet.deliveries()
        recoveries = recovery_times(fleet.traces, outages)
        return {
            "report": report,
            "orders_at_kill": len(open_at_kill),
            "orders_lost": len(open_at_kill - known_at_end),
            "orders_twice": sum(1 for times in delivered.values() if times > 1),
            # From the order book, which outlives the control process (its own figures
            # start again at its restart).
            "tasks_per_hour": sum(delivered.values()) / (seconds / 3600.0),
            "recoveries": recoveries,
        }


def _outage_period(seconds: float) -> float:
    """How often each vehicle's link goes down: every 10 minutes, at least twice a run."""
    return min(OUTAGE_EVERY_S, seconds / 2)


def _fault_plan(
    vehicles: list[str], seconds: float, kill_vehicle: bool
) -> list[tuple[float, str, str]]:
    """When each fault comes: outages spread over every period, r1 at a third, control
    at two thirds (and a vehicle killed while it is down)."""
    plan: list[tuple[float, str, str]] = []
    period = _outage_period(seconds)
    for i, vehicle in enumerate(vehicles):
        at = (i + 0.5) * period / len(vehicles)
        while at < seconds - OUTAGE_S - 10:
            plan.append((at, "outage", vehicle))
            at += period
    plan += [(seconds / 3, "kill", "r1"), (seconds / 3 + 1, "start", "r1")]
    plan += [(2 * seconds / 3, "kill", "control")]
    if kill_vehicle:
        plan.append((2 * seconds / 3 + 1, "kill", vehicles[-1]))
    plan.append((2 * seconds / 3 + 5, "start", "control"))
    return sorted(plan)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--vehicles", type=int, default=20)
    parser.add_argument("--minutes", type=float, default=30.0)
    parser.add_argument("--load", type=float, default=0.7)
    parser.add_argument("--layout", default=None)
    parser.add_argument("--kill-vehicle", action="store_true")
    args = parser.parse_args()
    # Stopped by SIGTERM too, the hosts, their processes and the namespaces go with it.
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))
    calm = run(args, faults=False)
    rough = run(args, faults=True)
    ratio = rough["tasks_per_hour"] / calm["tasks_per_hour"] if calm["tasks_per_hour"] else math.nan
    recovered = sorted(rough["recoveries"])
    print(f"moved again after the link returned, s: {[round(r, 2) for r in recovered]}")
    back = p99(recovered)
    rows = []
    for label, result, faults_run in (
        ("without faults", calm, False),
        ("with faults", rough, True),
    ):
        report = result["report"]
        rows.append(
            [
                label,
                report.collisions,
                report.lock_overlaps,
                f"{sum(report.outside_m.values()):.2f}",
                f"{result['tasks_per_hour']:.0f}",
                f"{p99(result['recoveries']):.2f} ({len(result['recoveries'])})"
                if result["recoveries"]
                else "-",
                f"{result['orders_lost']} / {result['orders_twice']} "
                f"(of {result['orders_at_kill']})"
                if faults_run
                else f"- / {result['orders_twice']}",
            ]
        )
    table = markdown_table(
        [
            "run",
            "collisions (goal 0)",
            "lock overlaps (goal 0)",
            "m outside locked floor (goal 0)",
            "orders delivered per hour (order book)",
            "moves again after its link returns, p99 s (outages) (goal <= 3)",
            "orders lost / done twice across the control restart (open then) (goal 0 / 0)",
        ],
        rows,
    )
    layout = args.layout or "the demo warehouse"
    body = (
        f"{args.vehicles} vehicle processes, two routers and the control process, each "
        f"on a host (network namespace) of its own, over Zenoh with mutual TLS, on "
        f"{layout}, {args.minutes:g} minutes at load {args.load:g}. With faults: every "
        f"vehicle {LOSS_PERCENT} % loss, {CAP_KBIT} kbit/s each way, a {OUTAGE_S:g} s "
        f"outage every {_outage_period(args.minutes * 60.0) / 60:g} minutes; router r1 "
        f"killed at a third, the control process at two thirds"
        + (", and a vehicle killed while it is down" if args.kill_vehicle else "")
        + f".\n\n{table}\n\nGoals: throughput with faults {ratio:.0%} of without "
        f"(>= 80 %: {'met' if ratio >= 0.8 else 'missed'}); moving again within 3 s of the link's "
        f"return, p99 {back:.2f} s ({'met' if back <= 3.0 else 'missed'}).\n"
    )
    name = "netfaults" if args.layout is None else f"netfaults-{args.layout.replace(':', '-')}"
    command = (
        ".venv/bin/python bench/netfaults.py"
        + (f" --vehicles {args.vehicles}" if args.vehicles != 20 else "")
        + (f" --minutes {args.minutes:g}" if args.minutes != 30.0 else "")
        + (f" --layout {args.layout}" if args.layout else "")
        + (" --kill-vehicle" if args.kill_vehicle else "")
    )
    publish(
        name, f"A fleet across hosts under faults: {layout} (bench/netfaults.py)", body, command
    )


if __name__ == "__main__":
    main()
