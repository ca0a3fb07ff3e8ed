"""Fleet benchmark: throughput, safety, bandwidth with groups vs broadcast, sim speed.

Runs the demo warehouse with 10, 20, 50, 100 and 200 AGVs (seeded, 30 simulated
minutes each by default), once with collision groups and once with ``--broadcast``
(every AGV votes on every request), and records the measured figures in
BENCHMARKS.md. Large sizes take long; ``--sizes`` and ``--minutes`` shorten the run.

    python -m bench.fleet [--sizes 10,20,50] [--minutes 30] [--seed 1]
"""

from __future__ import annotations

import argparse
import time

from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

from agv_app.fleet import Fleet, FleetConfig
from bench.report import markdown_table, publish

__all__ = ["main", "run_one"]


def run_one(
    agvs: int, *, minutes: float, seed: int, broadcast: bool, progress: Progress
) -> dict[str, float]:
    """Run one fleet and return its figures."""
    fleet = Fleet(config=FleetConfig(agvs=agvs, seed=seed, broadcast=broadcast))
    label = f"{agvs} AGVs {'broadcast' if broadcast else 'groups'}"
    bar = progress.add_task(label, total=minutes * 60)
    started = time.perf_counter()
    fleet.run(minutes * 60, lambda now: progress.update(bar, completed=now))
    return fleet.summary(time.perf_counter() - started)


def main(argv: list[str] | None = None) -> None:
    """Run the benchmark and publish its section of BENCHMARKS.md."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--sizes", default="10,20,50,100,200")
    parser.add_argument("--minutes", type=float, default=30.0)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args(argv)
    sizes = [int(s) for s in args.sizes.split(",") if s]
    rows = []
    with Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        TextColumn("{task.completed:.0f}/{task.total:.0f} sim s"),
        TimeElapsedColumn(),
    ) as progress:
        for n in sizes:
            grouped = run_one(
                n, minutes=args.minutes, seed=args.seed, broadcast=False, progress=progress
            )
            broad = run_one(
                n, minutes=args.minutes, seed=args.seed, broadcast=True, progress=progress
            )
            ratio = grouped["bytes_per_agv_per_s"] / max(broad["bytes_per_agv_per_s"], 1e-9)
            role_bytes = sum(v for k, v in grouped.items() if k.startswith("wire_channel_bytes"))
            role_broad = sum(v for k, v in broad.items() if k.startswith("wire_channel_bytes"))
            rows.append(
                [
                    n,
                    grouped["tasks_created"],
                    grouped["tasks_completed"],
                    grouped["tasks_per_hour"],
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
        "tasks created",
        "tasks done",
        "tasks/h",
        "collisions",
        "lock overlaps",
        "deadlocks (groups / broadcast)",
        "B/s per AGV, groups",
        "B/s per AGV, broadcast",
        "groups / broadcast",
        "session B/s per AGV (groups / broadcast)",
        "sim s per wall s",
    ]
    body = (
        f"Demo warehouse, seed {args.seed}, {args.minutes:g} simulated minutes per run, "
        "t_update 1 s, 5 ms delay. Bytes per AGV per second count every frame the AGVs' "
        "nodes sent (properties, session channels, acks); session B/s counts the "
        "collision and task protocols alone. Deadlocks: AGVs stalled over 180 s.\n\n"
        + markdown_table(header, rows)
    )
    command = f"python -m bench.fleet --sizes {args.sizes} --minutes {args.minutes:g}"
    publish("fleet", "AGV fleet: throughput, safety, bandwidth", body, command)


if __name__ == "__main__":
    main()
