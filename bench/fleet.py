"""Fleet benchmark: the traffic protocol against the central baseline, at load.

Runs the same fleet twice per seed, side by side in one run: once with the AGVs'
own traffic protocol (collision groups) and once with the central baseline
(``--traffic central``: one first-come-first-served scheduler, no network), on the
same layout, vehicles, task stream and seed. Then it checks the goals of issue 11 and
records both tables in BENCHMARKS.md:

* 0 collisions, 0 lock overlaps, 0 waits over 180 s, ``max_wait`` < 120 s;
* throughput >= 50% of the free-flow bound, and >= the central baseline's.

Bandwidth (groups against broadcast) is measured by ``bench/fleet_bandwidth.py``.

    python -m bench.fleet [--agvs 20] [--load 0.9] [--minutes 30] [--seeds 1,2,3,4,5]
                          [--layout FILE] [--jobs N]
    python -m bench.fleet --time-shares [--agvs 20] [--load 0.9] [--minutes 10] [--seeds 5]

``--time-shares`` runs nothing side by side: it prints where the AGVs' time goes in one
protocol run per seed (:func:`time_shares`) and writes nothing.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from collections import Counter
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from pathlib import Path

from agv_app.fleet import Fleet, FleetConfig
from agv_app.layout.json_format import load_any
from agv_app.tasks import check_load
from agv_app.vehicle.controller import DEFAULT_ADVANCE_M, AgvController
from bench.report import markdown_table, publish

__all__ = ["Goal", "activity", "collected", "goals", "main", "run_one", "time_shares"]

MODES = ("protocol", "central")
MAX_WAIT_GOAL_S = 120.0
FREE_FLOW_SHARE_GOAL = 0.5


def run_one(
    agvs: int,
    minutes: float,
    seed: int,
    traffic: str,
    load: float,
    layout: str | None = None,
    report_every: float = 5.0,
    advance_m: float = DEFAULT_ADVANCE_M,
) -> dict[str, float]:
    """Run one fleet and return its figures (sim speed from this process's CPU time).

    Every ``report_every`` simulated minutes it prints the figures so far as one JSON
    line, so a run cut short on a busy machine still shows what it measured.
    ``advance_m``: the AGVs' request length (``FleetConfig.advance_m``), in both modes.
    """
    floor = load_any(layout) if layout else None
    cfg = FleetConfig(agvs=agvs, seed=seed, load=load, traffic=traffic, advance_m=advance_m)
    fleet = Fleet(floor, cfg)
    started = time.process_time()
    done = 0.0
    while done < minutes:
        chunk = min(report_every, minutes - done)
        fleet.run(chunk * 60)
        done += chunk
        so_far = fleet.summary(time.process_time() - started)
        print(json.dumps({"seed": seed, "traffic": traffic, "minutes": done, **so_far}), flush=True)
    return fleet.summary(time.process_time() - started)


def activity(agv: AgvController) -> str:
    """What ``agv`` is doing now: its phase (``to_home+task`` when it drives home with
    the next task awarded), then, driving, whether it stands, drives at top speed,
    brakes for the end of its locks, or is otherwise slower (accelerating, the route's
    end)."""
    phase = agv.phase
    if phase == "to_home" and agv.pending_task is not None:
        phase = "to_home+task"
    if agv.vehicle.remaining() <= 1e-9 or phase in ("home", "at_pick", "at_drop"):
        return phase
    vehicle, spec = agv.vehicle, agv.spec
    if vehicle.speed == 0.0:
        return f"{phase}: standing"
    if vehicle.speed >= spec.max_speed_m_s - 1e-6:
        return f"{phase}: top speed"
    lock_end = agv.book.lock_end(default=vehicle.s)
    short = lock_end - vehicle.s < spec.braking_distance(vehicle.speed) + 0.6
    if lock_end < vehicle.route.length - 1e-6 and short:
        return f"{phase}: braking for the lock end"
    return f"{phase}: slower"


def time_shares(agvs: int, minutes: float, seed: int, load: float) -> dict[str, float]:
    """The share of the AGVs' time in each :func:`activity`, largest first (one
    protocol run on the demo warehouse, counted every step)."""
    fleet = Fleet(None, FleetConfig(agvs=agvs, seed=seed, load=load))
    counts: Counter[str] = Counter()
    for _ in range(round(minutes * 60 / fleet.config.dt)):
        fleet.step()
        counts.update(activity(agv) for agv in fleet.agvs.values())
    total = sum(counts.values())
    return {name: n / total for name, n in counts.most_common()}


@dataclass(frozen=True, slots=True)
class Goal:
    """One goal, what was measured and whether it was met."""

    name: str
    measured: str
    met: bool


def goals(runs: dict[tuple[int, str], dict[str, float]], seeds: list[int]) -> list[Goal]:
    """Check the goals on the protocol's runs (and against the central ones)."""
    ours = [runs[(s, "protocol")] for s in seeds]
    theirs = [runs[(s, "central")] for s in seeds]
    out = []
    for key, label in (
        ("collisions", "0 collisions"),
        ("lock_overlaps", "0 lock overlaps"),
        ("deadlocks", "0 waits over 180 s"),
    ):
        total = sum(r[key] for r in ours)
        out.append(Goal(label, f"{total:g} in {len(seeds)} runs", total == 0))
    worst = max(r["max_wait"] for r in ours)
    out.append(Goal(f"max_wait < {MAX_WAIT_GOAL_S:g} s", f"{worst:g} s (worst seed)", worst < 120))
    shares = [r["tasks_per_hour"] / max(r["free_flow_tasks_per_hour"], 1e-9) for r in ours]
    out.append(
        Goal(
            f"throughput >= {FREE_FLOW_SHARE_GOAL:.0%} of free flow",
            f"{min(shares):.0%} worst seed, {sum(shares) / len(shares):.0%} mean",
            min(shares) >= FREE_FLOW_SHARE_GOAL,
        )
    )
    wins = [a["tasks_per_hour"] >= b["tasks_per_hour"] for a, b in zip(ours, theirs, strict=True)]
    total_ours = sum(r["tasks_per_hour"] for r in ours)
    total_theirs = sum(r["tasks_per_hour"] for r in theirs)
    out.append(
        Goal(
            "throughput >= the central baseline's",
            f"{total_ours / len(seeds):.1f} against {total_theirs / len(seeds):.1f} tasks/h "
            f"(mean); at least as high on {sum(wins)} of {len(seeds)} seeds",
            all(wins),
        )
    )
    return out


def _row(seed: int, mode: str, r: dict[str, float]) -> list[object]:
    share = r["tasks_per_hour"] / max(r["free_flow_tasks_per_hour"], 1e-9)
    return [
        seed,
        mode,
        f"{r['minutes']:g}",
        r["tasks_created"],
        r["tasks_completed"],
        r["tasks_per_hour"],
        r["free_flow_tasks_per_hour"],
        f"{share:.0%}",
        r["collisions"],
        r["lock_overlaps"],
        r["deadlocks"],
        r["stalls_60s"],
        r["max_wait"],
        r["waiting_share"],
        r["sim_speed"],
    ]


def main(argv: list[str] | None = None) -> None:
    """Run the benchmark and publish its section of BENCHMARKS.md."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--agvs", type=int, default=20)
    parser.add_argument(
        "--load", type=float, default=0.9, help="share of what the fleet and floor carry, (0, 1]"
    )
    parser.add_argument("--minutes", type=float, default=30.0, help="simulated minutes per run")
    parser.add_argument("--seeds", default="1,2,3,4,5")
    parser.add_argument("--layout", help="layout file (.json or openTCS .xml); default: demo")
    parser.add_argument(
        "--advance",
        type=float,
        default=DEFAULT_ADVANCE_M,
        help=f"request length in both modes, m (default {DEFAULT_ADVANCE_M:g})",
    )
    parser.add_argument(
        "--jobs", type=int, default=os.cpu_count() or 1, help="runs in parallel, one core each"
    )
    parser.add_argument(
        "--collect",
        type=Path,
        help="run nothing: publish the runs logged in this directory (run_SEED_TRAFFIC.txt, "
        "run_one's JSON lines, e.g. from runs started as separate processes); runs cut "
        "short count, each seed's two at the minutes both reached",
    )
    parser.add_argument(
        "--time-shares",
        action="store_true",
        help="print where the AGVs' time goes in one protocol run per seed; write nothing",
    )
    args = parser.parse_args(argv)
    try:
        check_load(args.load)
    except ValueError as exc:
        raise SystemExit(f"bench.fleet: --load: {exc}") from exc
    try:
        FleetConfig(advance_m=args.advance)  # the fleet's own check, before any run
    except ValueError as exc:
        raise SystemExit(f"bench.fleet: --advance: {exc}") from exc
    seeds = [int(s) for s in args.seeds.split(",") if s]
    if args.time_shares:
        for seed in seeds:
            print(f"seed {seed}, {args.agvs} AGVs, load {args.load:g}, {args.minutes:g} min:")
            for name, share in time_shares(args.agvs, args.minutes, seed, args.load).items():
                print(f"  {share:6.1%}  {name}")
        return
    if args.collect is not None:
        _publish(args, seeds, collected(args.collect, seeds))
    else:
        _publish(args, seeds, _run_all(args, seeds))


def collected(folder: Path, seeds: list[int]) -> dict[tuple[int, str], dict[str, float]]:
    """The figures each run logged in ``folder`` (``run_SEED_TRAFFIC.txt``), for each
    seed at the largest simulated minutes both of its runs reached (side by side)."""
    runs: dict[tuple[int, str], dict[str, float]] = {}
    for seed in seeds:
        logged = {}
        for mode in MODES:
            lines = (folder / f"run_{seed}_{mode}.txt").read_text().splitlines()
            points = [json.loads(line) for line in lines if line.startswith("{")]
            logged[mode] = {p["minutes"]: p for p in points}
        both = max(set.intersection(*(set(m) for m in logged.values())))
        for mode in MODES:
            figures = logged[mode][both]
            runs[(seed, mode)] = {k: v for k, v in figures.items() if k not in ("seed", "traffic")}
    return runs


def _run_all(args: argparse.Namespace, seeds: list[int]) -> dict[tuple[int, str], dict[str, float]]:
    runs: dict[tuple[int, str], dict[str, float]] = {}
    with ProcessPoolExecutor(max_workers=args.jobs) as pool:
        futures = {
            pool.submit(
                run_one,
                args.agvs,
                args.minutes,
                seed,
                mode,
                args.load,
                args.layout,
                advance_m=args.advance,
            ): (seed, mode)
            for seed in seeds
            for mode in MODES
        }
        for future in as_completed(futures):
            seed, mode = futures[future]
            runs[(seed, mode)] = {"minutes": args.minutes, **future.result()}
    return runs


def _publish(
    args: argparse.Namespace, seeds: list[int], runs: dict[tuple[int, str], dict[str, float]]
) -> None:
    header = [
        "seed",
        "traffic",
        "sim minutes",
        "tasks created",
        "tasks done",
        "tasks/h",
        "free-flow tasks/h",
        "of free flow",
        "collisions",
        "lock overlaps",
        "waits > 180 s",
        "waits > 60 s",
        "longest wait, s",
        "waiting share",
        "sim s per CPU s",
    ]
    rows = [_row(seed, mode, runs[(seed, mode)]) for seed in seeds for mode in MODES]
    checked = goals(runs, seeds)
    goal_rows = [[g.name, g.measured, "yes" if g.met else "**no**"] for g in checked]
    where = args.layout or "the demo warehouse"
    reached = min(r["minutes"] for r in runs.values())
    short = (
        f" (runs cut short on a busy machine: figures at the simulated minutes each reached, "
        f"at least {reached:g})"
        if reached < args.minutes
        else ""
    )
    body = (
        f"{args.agvs} AGVs on {where}, load {args.load:g}, {args.minutes:g} simulated minutes "
        f"per run{short}, seeds {args.seeds}; t_update 1 s, 5 ms delay, requests reaching "
        f"{args.advance:g} m beyond the locks. Each seed runs twice "
        "on the same layout, vehicles, task stream and seed: `protocol` is the AGVs' own traffic "
        "protocol (collision groups, the longest-waiting request first, direction claims), "
        "`central` the baseline "
        "(`objectplaces sim --traffic central`: one scheduler sees every lock and grants "
        "requests first come, first served, with no network; the AGVs keep their resting "
        "places and yield at dead ends). Free-flow tasks/h, waits and the longest wait as "
        "in docs/fleet.md.\n\n"
        + markdown_table(header, rows)
        + "\n\nGoals (issue 11), on the protocol's runs:\n\n"
        + markdown_table(["goal", "measured", "met"], goal_rows)
    )
    command = (
        f".venv/bin/python -m bench.fleet --agvs {args.agvs} --load {args.load:g} "
        f"--minutes {args.minutes:g} --seeds {args.seeds}"
        + (f" --layout {args.layout}" if args.layout else "")
        + (f" --advance {args.advance:g}" if args.advance != DEFAULT_ADVANCE_M else "")
    )
    publish("fleet", "AGV fleet at load: the protocol against a central scheduler", body, command)


if __name__ == "__main__":
    main()
