"""Fleet benchmark: throughput, safety, bandwidth with groups vs broadcast, sim speed.

Runs the demo warehouse with 10, 20, 50, 100 and 200 AGVs (seeded, 30 simulated
minutes each by default), once with collision groups and once with ``--broadcast``
(every AGV votes on every request), and records the measured figures in
BENCHMARKS.md. Large sizes take long; ``--sizes`` and ``--minutes`` shorten the run.

``--against DIR`` runs every job a second time with the tree checked out at ``DIR``
(``git worktree add DIR <commit>``), side by side in the same run, and adds a table
of both trees' sim speed: a change to the fleet shows there whether it costs time.

Tasks arrive at the rate that keeps ``--load`` of the AGVs busy (default 0.7, see
``agv_app.tasks.load``); the table sets the tasks done per hour beside the free-flow
bound and the long waits (docs/fleet.md says what each figure means).

    python -m bench.fleet [--sizes 10,20,50] [--minutes 30] [--seed 1] [--load 0.7]
                          [--against DIR]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

from agv_app.fleet import Fleet, FleetConfig
from agv_app.tasks import DEFAULT_LOAD, check_load
from bench.report import markdown_table, publish

__all__ = ["main", "run_elsewhere", "run_one"]


def run_one(
    agvs: int, minutes: float, seed: int, broadcast: bool, load: float = DEFAULT_LOAD
) -> dict[str, float]:
    """Run one fleet and return its figures (sim speed from this process's CPU time)."""
    fleet = Fleet(config=FleetConfig(agvs=agvs, seed=seed, broadcast=broadcast, load=load))
    started = time.process_time()
    fleet.run(minutes * 60)
    return fleet.summary(time.process_time() - started)


_RUN_ONE = (
    "import json, sys; from bench.fleet import run_one; "
    "print(json.dumps(run_one(*json.loads(sys.argv[1]))))"
)


def run_elsewhere(
    tree: Path, agvs: int, minutes: float, seed: int, broadcast: bool
) -> dict[str, float]:
    """:func:`run_one` with the code of another checkout ``tree``, in a child process
    (at that tree's own default load: older trees take no load)."""
    env = {**os.environ, "PYTHONPATH": str(tree)}
    args = json.dumps([agvs, minutes, seed, broadcast])
    done = subprocess.run(
        [sys.executable, "-c", _RUN_ONE, args],
        cwd=tree,
        env=env,
        capture_output=True,
        text=True,
        check=True,
    )
    figures: dict[str, float] = json.loads(done.stdout.strip().splitlines()[-1])
    return figures


def _plan(sizes: list[int], minutes: str) -> list[tuple[int, float]]:
    """Pair each size with its simulated minutes (one value for all, or one per size)."""
    values = [float(m) for m in minutes.split(",") if m]
    if len(values) == 1:
        values *= len(sizes)
    if len(values) != len(sizes):
        raise SystemExit(f"--minutes gives {len(values)} values for {len(sizes)} sizes")
    return list(zip(sizes, values, strict=True))


def main(argv: list[str] | None = None) -> None:
    """Run the benchmark and publish its section of BENCHMARKS.md."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--sizes", default="10,20,50,100,200")
    parser.add_argument(
        "--minutes", default="30", help="simulated minutes: one value, or one per size"
    )
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument(
        "--load", type=float, default=DEFAULT_LOAD, help="target share of busy AGVs, (0, 1]"
    )
    parser.add_argument(
        "--jobs",
        type=int,
        default=os.cpu_count() or 1,
        help="runs in parallel (each run is one process on one core)",
    )
    parser.add_argument(
        "--against", type=Path, help="also run every job with the checkout in this directory"
    )
    args = parser.parse_args(argv)
    try:
        check_load(args.load)
    except ValueError as exc:
        raise SystemExit(f"bench.fleet: --load: {exc}") from exc
    sizes = [int(s) for s in args.sizes.split(",") if s]
    plan = _plan(sizes, args.minutes)
    jobs = [(n, m, broadcast) for n, m in plan for broadcast in (False, True)]
    trees = ["this", "against"] if args.against else ["this"]
    results: dict[tuple[int, bool], dict[str, float]] = {}
    baseline: dict[tuple[int, bool], dict[str, float]] = {}
    with (
        Progress(TextColumn("{task.description}"), BarColumn(), TimeElapsedColumn()) as progress,
        ProcessPoolExecutor(max_workers=args.jobs) as pool,
    ):
        bar = progress.add_task("fleet runs", total=len(jobs) * len(trees))
        futures = {}
        # Largest first; a job's two trees side by side, so both see the same load.
        for n, m, broadcast in sorted(jobs, key=lambda j: -j[0] * j[1]):
            for tree in trees:
                future = (
                    pool.submit(run_one, n, m, args.seed, broadcast, args.load)
                    if tree == "this"
                    else pool.submit(run_elsewhere, args.against, n, m, args.seed, broadcast)
                )
                futures[future] = (tree, n, broadcast)
        for future in as_completed(futures):
            tree, n, broadcast = futures[future]
            (results if tree == "this" else baseline)[(n, broadcast)] = future.result()
            progress.advance(bar)
    rows = []
    for n, minutes in plan:
        grouped, broad = results[(n, False)], results[(n, True)]
        ratio = grouped["bytes_per_agv_per_s"] / max(broad["bytes_per_agv_per_s"], 1e-9)
        role_bytes = sum(v for k, v in grouped.items() if k.startswith("wire_channel_bytes"))
        role_broad = sum(v for k, v in broad.items() if k.startswith("wire_channel_bytes"))
        rows.append(
            [
                n,
                f"{minutes:g}",
                grouped["tasks_created"],
                grouped["tasks_completed"],
                grouped["tasks_per_hour"],
                grouped["free_flow_tasks_per_hour"],
                grouped["stalls_60s"],
                grouped["max_wait"],
                grouped["collisions"] + broad["collisions"],
                grouped["lock_overlaps"] + broad["lock_overlaps"],
                f"{grouped['deadlocks']} / {broad['deadlocks']}",
                grouped["bytes_per_agv_per_s"],
                broad["bytes_per_agv_per_s"],
                f"{ratio:.2f}",
                f"{role_bytes:.0f} / {role_broad:.0f}",
                grouped["sim_speed"],
            ]
        )
    header = [
        "AGVs",
        "sim minutes",
        "tasks created",
        "tasks done",
        "tasks/h",
        "free-flow tasks/h",
        "waits > 60 s",
        "longest wait, s",
        "collisions",
        "lock overlaps",
        "deadlocks (groups / broadcast)",
        "B/s per AGV, groups",
        "B/s per AGV, broadcast",
        "groups / broadcast",
        "session B/s per AGV (groups / broadcast)",
        "sim s per CPU s (groups)",
    ]
    body = (
        f"Demo warehouse, seed {args.seed}, load {args.load:g}, t_update 1 s, 5 ms delay; "
        "the minutes column "
        "gives each run's simulated time. Bytes per AGV per second count every frame the "
        "AGVs' nodes sent (properties, session channels, acks); session B/s counts the "
        "collision and task protocols alone. Deadlocks: AGVs stalled over 180 s; free-flow "
        "tasks/h, waits > 60 s and the longest wait (with groups) as in docs/fleet.md. Sim speed "
        "is simulated seconds per CPU second of the run's own process (one core).\n\n"
        + markdown_table(header, rows)
        + "\n\nGoals (issue 5): 0 violations at every size; bandwidth with groups <= 1/5 of "
        "broadcast at 50 AGVs; 100 AGVs at >= 10x real time on one core."
    )
    if args.against:
        body += "\n\n" + _comparison(plan, results, baseline, args.against)
    command = (
        f".venv/bin/python -m bench.fleet --sizes {args.sizes} --minutes {args.minutes} "
        f"--load {args.load:g}"
    )
    if args.against:
        command += f" --against {args.against}"
    publish("fleet", "AGV fleet: throughput, safety, bandwidth (bench/fleet.py)", body, command)


def _comparison(
    plan: list[tuple[int, float]],
    results: dict[tuple[int, bool], dict[str, float]],
    baseline: dict[tuple[int, bool], dict[str, float]],
    against: Path,
) -> str:
    """The table of sim speed (and tasks done, which must agree) of both trees."""
    rows = []
    for n, minutes in plan:
        for broadcast in (False, True):
            new, old = results[(n, broadcast)], baseline[(n, broadcast)]
            rows.append(
                [
                    n,
                    "broadcast" if broadcast else "groups",
                    f"{minutes:g}",
                    f"{new['tasks_completed']} / {old['tasks_completed']}",
                    new["sim_speed"],
                    old["sim_speed"],
                    f"{new['sim_speed'] / max(old['sim_speed'], 1e-9):.2f}",
                ]
            )
    header = [
        "AGVs",
        "mode",
        "sim minutes",
        "tasks done (this / against)",
        "sim s per CPU s, this tree",
        f"sim s per CPU s, {against.name}",
        "this / against",
    ]
    return (
        f"Against the checkout in `{against}`, measured in the same run, each job's two "
        "trees side by side:\n\n" + markdown_table(header, rows)
    )


if __name__ == "__main__":
    main()
