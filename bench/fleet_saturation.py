"""Fleet saturation benchmark: more AGVs than the floor carries, with and without a
limit on the tasks on the floor.

At a fixed load (the share of AGVs kept busy) the task rate grows with the fleet; a
floor carries only so many moving AGVs, and past that more tasks at once fill its
lanes. This runs the demo warehouse with growing fleets and no limit, then the largest
fleet with the task desk holding the tasks on the floor to each of ``--limits``
(``FleetConfig.max_open_tasks``), each on every seed, side by side in one run. The
baseline is the same fleet without a limit.

    python -m bench.fleet_saturation [--sizes 20,35,50] [--limits 15,20,30] [--seeds 1,2]
                                     [--minutes 10] [--load 0.7] [--jobs 2]
"""

from __future__ import annotations

import argparse
import time
from concurrent.futures import ProcessPoolExecutor, as_completed

from rich.progress import Progress

from agv_app.fleet import Fleet, FleetConfig
from agv_app.tasks import check_load
from bench.report import markdown_table, publish

__all__ = ["main", "run_one"]

Job = tuple[int, int | None, int]
"""AGVs, the limit on open tasks (None: none), seed."""


def run_one(
    agvs: int, limit: int | None, seed: int, minutes: float, load: float
) -> dict[str, float]:
    """Run one fleet on the demo warehouse and return its figures."""
    fleet = Fleet(None, FleetConfig(agvs=agvs, seed=seed, load=load, max_open_tasks=limit))
    started = time.process_time()
    fleet.run(minutes * 60)
    return fleet.summary(time.process_time() - started)


def _ints(text: str) -> list[int]:
    return [int(x) for x in text.split(",") if x.strip()]


def main() -> None:
    """Parse arguments, run every job, print and record the table."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", default="20,35,50")
    parser.add_argument("--limits", default="15,20,30")
    parser.add_argument("--seeds", default="1,2")
    parser.add_argument("--minutes", type=float, default=10.0)
    parser.add_argument("--load", type=float, default=0.7)
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args()
    sizes, limits, seeds = _ints(args.sizes), _ints(args.limits), _ints(args.seeds)
    check_load(args.load)
    if not sizes or not seeds or min(sizes + limits + seeds) < 1 or args.minutes <= 0:
        parser.error("--sizes, --limits and --seeds take whole numbers >= 1, --minutes > 0")
    largest = max(sizes)
    jobs: list[Job] = [(n, None, s) for n in sizes for s in seeds]
    jobs += [(largest, lim, s) for lim in limits for s in seeds]
    results: dict[Job, dict[str, float]] = {}
    with (
        Progress() as progress,
        ProcessPoolExecutor(max_workers=max(1, args.jobs)) as pool,
    ):
        bar = progress.add_task("fleets", total=len(jobs))
        futures = {pool.submit(run_one, *job, args.minutes, args.load): job for job in jobs}
        for future in as_completed(futures):
            results[futures[future]] = future.result()
            progress.advance(bar)
    rows = []
    for job in jobs:
        agvs, limit, seed = job
        m = results[job]
        rows.append(
            [
                agvs,
                "none" if limit is None else limit,
                seed,
                f"{m['tasks_per_hour']:.0f}",
                f"{m['free_flow_tasks_per_hour']:.0f}",
                int(m["stalls_60s"]),
                int(m["deadlocks"]),
                f"{m['max_wait']:.1f}",
                f"{m['waiting_share']:.2f}",
                f"{m['task_time_mean']:.0f}",
                int(m["collisions"] + m["lock_overlaps"]),
            ]
        )
    header = [
        "AGVs", "open tasks at most", "seed", "tasks/h", "free-flow tasks/h", "waits > 60 s",
        "waits > 180 s", "longest wait, s", "waiting share", "mean task time, s", "violations",
    ]  # fmt: skip
    best = {
        s: max(
            (
                (results[(largest, lim, s)]["tasks_per_hour"], lim)
                for lim in [None, *limits]
                if (largest, lim, s) in results
            ),
            key=lambda found: found[0],
        )
        for s in seeds
    }
    summary = "; ".join(
        f"seed {s}: {t:.0f} tasks/h with {'no limit' if lim is None else f'at most {lim}'}"
        f" (no limit: {results[(largest, None, s)]['tasks_per_hour']:.0f})"
        for s, (t, lim) in best.items()
    )
    body = (
        f"The demo warehouse, load {args.load}, {args.minutes:g} simulated minutes per run, "
        "the protocol's traffic (collision groups). Tasks/h: delivered; free flow: the same "
        "tasks' routes driven at full speed, no waiting; waits: single waits of an AGV that "
        "wants to move (over 180 s counts as a deadlock and makes `objectplaces sim` exit "
        "1); task time: from creation to delivery (with a limit, the time a task waits at "
        "the desk included); violations: collisions and lock overlaps.\n\n"
        f"{markdown_table(header, rows)}\n\n"
        f"Best throughput of {largest} AGVs: {summary}.\n"
    )
    command = (
        f".venv/bin/python -m bench.fleet_saturation --sizes {args.sizes} --limits "
        f"{args.limits} --seeds {args.seeds} --minutes {args.minutes:g} --load {args.load} "
        f"--jobs {args.jobs}"
    )
    publish("fleet_saturation", "Fleet saturation: more AGVs than the floor carries", body, command)


if __name__ == "__main__":
    main()
