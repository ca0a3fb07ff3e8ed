"""Long-run benchmark: one fleet for hours of simulated time, checked for drift.

A fleet that runs well for 30 minutes may still leak: records nobody takes out of a
tuplespace, sessions never closed, tables that only grow, throughput that sinks as
they do. This runs one seeded fleet for ``--hours`` simulated hours and, every
``--every`` simulated minutes, records the tasks done in the interval, the safety and
stall figures so far, the process's memory and the objects the collector tracks. The
baseline is the run's own first hour: the last hour's throughput, memory and objects
are compared with it.

    python -m bench.long_run [--agvs 20] [--load 0.9] [--hours 6] [--every 20] [--seed 7]
"""

from __future__ import annotations

import argparse
import gc
import resource
import time
from dataclasses import dataclass
from pathlib import Path

from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

from agv_app.fleet import Fleet, FleetConfig
from bench.report import markdown_table, publish

__all__ = ["Interval", "main", "measure"]


@dataclass(frozen=True, slots=True)
class Interval:
    """The figures at the end of one interval (safety and waits: the run so far)."""

    hours: float
    tasks: int
    tasks_per_hour: float
    rss_mb: float
    objects: int
    collisions: int
    lock_overlaps: int
    double_assignments: int
    waits_over_180s: int
    waits_over_60s: int
    max_wait: float


def _rss_mb() -> float:
    """Resident memory of this process now (Linux), else its peak, in MB."""
    statm = Path("/proc/self/statm")
    if statm.exists():
        pages = int(statm.read_text().split()[1])
        return pages * resource.getpagesize() / 2**20
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def measure(
    agvs: int, load: float, hours: float, every_min: float, seed: int, progress: Progress
) -> list[Interval]:
    """Run the fleet and return one :class:`Interval` per ``every_min`` minutes."""
    # A drift test keeps the floor as busy as the fleet asks, past what it carries.
    fleet = Fleet(None, FleetConfig(agvs=agvs, seed=seed, load=load, load_of="fleet"))
    total = hours * 3600
    bar = progress.add_task(f"{agvs} AGVs, {hours:g} h", total=total)
    out: list[Interval] = []
    done_before = 0
    while fleet.now < total - 1e-6:
        span = min(every_min * 60, total - fleet.now)
        base = fleet.now
        fleet.run(span, lambda now: progress.update(bar, completed=now))
        gc.collect()
        s = fleet.summary()
        done = int(s["tasks_completed"])
        out.append(
            Interval(
                hours=round(fleet.now / 3600, 2),
                tasks=done - done_before,
                tasks_per_hour=round((done - done_before) * 3600 / (fleet.now - base), 1),
                rss_mb=round(_rss_mb(), 1),
                objects=len(gc.get_objects()),
                collisions=int(s["collisions"]),
                lock_overlaps=int(s["lock_overlaps"]),
                double_assignments=int(s["double_assignments"]),
                waits_over_180s=int(s["deadlocks"]),
                waits_over_60s=int(s["stalls_60s"]),
                max_wait=float(s["max_wait"]),
            )
        )
        done_before = done
    return out


def _hour(rows: list[Interval], first: bool) -> list[Interval]:
    """The intervals of the run's first (or last) hour."""
    end = rows[-1].hours
    return [r for r in rows if (r.hours <= 1.0 + 1e-9 if first else r.hours > end - 1.0 + 1e-9)]


def main() -> None:
    """Parse arguments, run, print and record the figures."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--agvs", type=int, default=20)
    parser.add_argument("--load", type=float, default=0.9)
    parser.add_argument("--hours", type=float, default=6.0)
    parser.add_argument("--every", type=float, default=20.0, help="simulated minutes")
    parser.add_argument("--seed", type=int, default=7)
    args = parser.parse_args()
    if args.hours < 2 or args.every <= 0 or args.every > 60:
        parser.error("--hours must be >= 2 (a first and a last hour) and 0 < --every <= 60")
    started = time.process_time()
    with Progress(TextColumn("{task.description}"), BarColumn(), TimeElapsedColumn()) as progress:
        rows = measure(args.agvs, args.load, args.hours, args.every, args.seed, progress)
    cpu = time.process_time() - started
    first, last = _hour(rows, first=True), _hour(rows, first=False)
    rate_first = sum(r.tasks for r in first) * 3600 / (len(first) * args.every * 60)
    rate_last = sum(r.tasks for r in last) * 3600 / (len(last) * args.every * 60)
    end = rows[-1]
    header = [
        "sim h",
        "tasks",
        "tasks/h",
        "RSS MB",
        "objects",
        "collisions",
        "lock overlaps",
        "double assignments",
        "waits > 180 s",
        "waits > 60 s",
        "max wait, s",
    ]
    table = markdown_table(
        header,
        [
            [
                r.hours,
                r.tasks,
                r.tasks_per_hour,
                r.rss_mb,
                f"{r.objects:,}",
                r.collisions,
                r.lock_overlaps,
                r.double_assignments,
                r.waits_over_180s,
                r.waits_over_60s,
                r.max_wait,
            ]
            for r in rows
        ],
    )
    body = (
        f"{args.agvs} AGVs on the demo warehouse, load {args.load} of the fleet's own rate "
        f"(past what the floor carries: `load_of='fleet'`), seed {args.seed}, "
        f"{args.hours:g} simulated hours in {cpu:.0f} s of CPU; a row every {args.every:g} "
        "simulated minutes (tasks: done in that interval; safety and waits: the run so far; "
        "RSS: this process's resident memory; objects: what the collector tracks after a "
        "collection).\n\n"
        f"{table}\n\n"
        "| last hour against the first | value |\n|---|---|\n"
        f"| tasks per hour | {rate_last:.0f} against {rate_first:.0f} "
        f"({rate_last / rate_first:.2f}x) |\n"
        f"| RSS | {last[-1].rss_mb} MB against {first[-1].rss_mb} MB "
        f"({last[-1].rss_mb - first[-1].rss_mb:+.1f} MB) |\n"
        f"| objects tracked | {last[-1].objects:,} against {first[-1].objects:,} "
        f"({last[-1].objects / first[-1].objects:.2f}x) |\n"
        f"| collisions, lock overlaps, double assignments, waits over 180 s (whole run) | "
        f"{end.collisions}, {end.lock_overlaps}, {end.double_assignments}, "
        f"{end.waits_over_180s} |\n"
    )
    command = (
        f".venv/bin/python -m bench.long_run --agvs {args.agvs} --load {args.load} "
        f"--hours {args.hours:g} --every {args.every:g} --seed {args.seed}"
    )
    publish("long_run", "Long run: a fleet for hours, checked for drift", body, command)


if __name__ == "__main__":
    main()
