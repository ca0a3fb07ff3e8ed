"""Fleet saturation benchmark: more AGVs than the floor carries, with and without a
limit on the tasks on the floor.

At a fixed load (the share of AGVs kept busy) the task rate grows with the fleet; a
floor carries only so many moving AGVs, and past that more tasks at once fill its
lanes. This runs a floor (the demo warehouse unless ``--layout generated:N``) with
growing fleets and no limit, then the largest fleet with the task desk holding the
tasks on the floor to each of ``--limits`` (``FleetConfig.max_open_tasks``; ``auto``:
the limit that follows the floor's long waits), each on every seed, side by side in one
run. The baseline is the same fleet without a limit.

    python -m bench.fleet_saturation [--sizes 20,35,50] [--limits 15,20,30,auto]
                                     [--seeds 1,2] [--minutes 10] [--load 0.7]
                                     [--layout generated:100] [--jobs 2]
"""

from __future__ import annotations

import argparse
import time
from concurrent.futures import ProcessPoolExecutor, as_completed

from rich.progress import Progress

from agv_app.fleet import Fleet, FleetConfig
from agv_app.layout.generated import generated_warehouse, parse_generated
from agv_app.layout.graph import Layout
from agv_app.tasks import check_load
from bench.report import markdown_table, publish

__all__ = ["main", "run_one"]

Job = tuple[int, int | str | None, int]
"""AGVs, the limit on open tasks (None: none; "auto": the limit that follows), seed."""


def _floor(layout: str | None) -> Layout | None:
    """The floor ``--layout`` names: None (the demo warehouse) or ``generated:N``."""
    if layout is None:
        return None
    count = parse_generated(layout)
    if count is None:
        raise ValueError(f"--layout takes generated:N, got {layout!r}")
    return generated_warehouse(count)


def run_one(
    agvs: int, limit: int | str | None, seed: int, minutes: float, load: float, layout: str | None
) -> dict[str, float]:
    """Run one fleet and return its figures, with the limit at the end (``auto``)."""
    # The load of the fleet alone: this floor is meant to be asked for more than it carries.
    config = FleetConfig(agvs=agvs, seed=seed, load=load, load_of="fleet", max_open_tasks=limit)
    fleet = Fleet(_floor(layout), config)
    started = time.process_time()
    fleet.run(minutes * 60)
    figures = dict(fleet.summary(time.process_time() - started))
    admission = fleet.desk.admission
    if admission is not None:
        figures["limit_end"] = admission.limit
        figures["limit_lowest"] = admission.lowest
        figures["limit_cuts"] = admission.cuts
    return figures


def _ints(text: str) -> list[int]:
    return [int(x) for x in text.split(",") if x.strip()]


def _limits(text: str) -> list[int | str]:
    return [x.strip() if x.strip() == "auto" else int(x) for x in text.split(",") if x.strip()]


def _limit_cell(limit: int | str | None, figures: dict[str, float]) -> str:
    if limit is None:
        return "none"
    if limit == "auto":
        return (
            f"auto (ends at {figures['limit_end']:.0f}, lowest {figures['limit_lowest']:.0f}, "
            f"{figures['limit_cuts']:.0f} cuts)"
        )
    return str(limit)


def main() -> None:
    """Parse arguments, run every job, print and record the table."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", default="20,35,50")
    parser.add_argument("--limits", default="15,20,30,auto")
    parser.add_argument("--seeds", default="1,2")
    parser.add_argument("--minutes", type=float, default=10.0)
    parser.add_argument("--load", type=float, default=0.7)
    parser.add_argument("--layout", help="generated:N (default: the demo warehouse)")
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args()
    try:
        sizes, limits, seeds = _ints(args.sizes), _limits(args.limits), _ints(args.seeds)
        check_load(args.load)
        _floor(args.layout)
    except ValueError as exc:
        parser.error(str(exc))
    fixed = [lim for lim in limits if isinstance(lim, int)]
    if not sizes or not seeds or min(sizes + fixed + seeds) < 1 or args.minutes <= 0:
        parser.error(
            "--sizes and --seeds take whole numbers >= 1, --limits those or auto, --minutes > 0"
        )
    largest = max(sizes)
    jobs: list[Job] = [(n, None, s) for n in sizes for s in seeds]
    jobs += [(largest, lim, s) for lim in limits for s in seeds]
    results: dict[Job, dict[str, float]] = {}
    with (
        Progress() as progress,
        ProcessPoolExecutor(max_workers=max(1, args.jobs)) as pool,
    ):
        bar = progress.add_task("fleets", total=len(jobs))
        futures = {
            pool.submit(run_one, *job, args.minutes, args.load, args.layout): job for job in jobs
        }
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
                _limit_cell(limit, m),
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
    named: dict[int | str | None, str] = {None: "no limit", "auto": "the automatic limit"}
    summary = "; ".join(
        f"seed {s}: {t:.0f} tasks/h with {named.get(lim, f'at most {lim}')}"
        f" (no limit: {results[(largest, None, s)]['tasks_per_hour']:.0f})"
        for s, (t, lim) in best.items()
    )
    body = (
        f"{'The demo warehouse' if args.layout is None else f'`{args.layout}`'}, load "
        f"{args.load}, {args.minutes:g} simulated minutes per run, "
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
        f"--jobs {args.jobs}" + ("" if args.layout is None else f" --layout {args.layout}")
    )
    if args.layout is None:
        section, title = "fleet_saturation", "Fleet saturation: more AGVs than the floor carries"
    else:
        section = "fleet_saturation_" + args.layout.replace(":", "_")
        title = f"Fleet saturation on {args.layout}"
    publish(section, title, body, command)


if __name__ == "__main__":
    main()
