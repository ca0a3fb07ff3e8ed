"""Run seeds of random floors with a fleet on each; replay one.

```sh
python -m tests.soak.floors --seeds 0-299 --jobs 2          # many seeds, with progress
python -m tests.soak.floors --seed 126                      # replay one, with its AGVs
python -m tests.soak.floors --seeds 0-299 --off keep_way_out --off drive_on_after
python -m tests.soak.floors --kind two-way --seeds 0-999 --jobs 2
```

Seed ``n`` of ``--kind one-way`` (the default) is the floor, fleet, load and task
stream that ``draw_floor_run(random.Random(n))`` draws
(``tests/agv_app/one_way_floors.py``): a crowded one-way floor, tasks for 300
simulated seconds and 200 more to finish them. ``--kind two-way`` draws small two-way
layouts with dead-end docks and crossings instead
(``tests/agv_app/two_way_floors.py``: tasks for 200 s, 200 more to finish them).
``--kind crossing``, ``areas`` and ``halls`` draw the shapes that make AGVs wait long
(``tests/agv_app/hard_floors.py``): two-way lanes crossing with stations and parking
at the arms' ends, a lane (or a lane with a lay-by) between two dead-end areas, one-way
halls joined by a two-way door.
The safety monitor checks every step (a collision or a lock overlap ends the seed);
at the end no AGV may have stalled past the stall limit, no wait may have passed the
fleet's wait bound (docs/traffic.md, "Bounded waits") and a task must be done.
``--off RULE`` runs the fleet without a traffic rule (``clear_merges``,
``clear_turn_offs``, ``keep_way_out``, ``drive_on_after``, ``detour_after``) or with
stations that call every winner at once (``one_at_a_time``) or that call an AGV whose
drop station another is bound for (``wait_for_drop``), to show what the rule is for.
Every failing seed is printed with its replay command; the exit status is 1 when any
seed failed.
"""

from __future__ import annotations

import argparse
import multiprocessing
import random
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from agv_app.fleet import Fleet, SafetyError
from tests.agv_app.hard_floors import DRAWS, HardRun, run_hard
from tests.agv_app.one_way_floors import FloorRun, draw_floor_run, run_floor
from tests.agv_app.two_way_floors import TwoWayRun, draw_two_way_run, run_two_way
from tests.agv_app.vehicles import vehicle_with
from tests.soak.runner import parse_seeds, seed_progress

__all__ = [
    "FLEET_RULES",
    "KINDS",
    "RULES",
    "FloorResult",
    "main",
    "replay_command",
    "run_floor_seed",
]

RULES: dict[str, Any] = {
    "clear_merges": False,
    "clear_turn_offs": False,
    "keep_way_out": False,
    "drive_on_after": None,
    "detour_after": None,
}
"""The traffic rules ``--off`` can switch off, and the ``AgvConfig`` value that does."""

FLEET_RULES: dict[str, Any] = {"one_at_a_time": False, "wait_for_drop": False}
"""The fleet's rules ``--off`` can switch off, and the ``FleetConfig`` value that does."""

KINDS: dict[str, tuple[Callable[[random.Random], Any], Callable[..., Fleet]]] = {
    "one-way": (draw_floor_run, run_floor),
    "two-way": (draw_two_way_run, run_two_way),
    **{kind: (draw, run_hard) for kind, draw in DRAWS.items()},
}
"""The floors ``--kind`` draws: how a seed's run is drawn, and how it is run."""


@dataclass(frozen=True, slots=True)
class FloorResult:
    """The outcome of one seed.

    Attributes:
        seed: the seed.
        run: what it drew.
        tasks_done: tasks delivered.
        stalls: waits past the stall limit (each AGV's wait counted once).
        yields: times an AGV backed off from the start of its route.
        drive_ons: times an AGV drove on past its destination to come back later.
        detours: times an AGV took another way to its destination.
        max_wait: the longest single wait, seconds.
        wait_bound: the fleet's wait bound, seconds (docs/traffic.md, "Bounded waits").
        standing: the AGVs still standing past the limit at the end, with their phase
            and the point their route started from.
        violation: the safety violation that ended the run, if any.
        wall_seconds: how long it took.
    """

    seed: int
    run: FloorRun | TwoWayRun | HardRun
    tasks_done: int
    stalls: int
    yields: int
    drive_ons: int
    detours: int
    max_wait: float
    wait_bound: float
    standing: tuple[tuple[str, str, str], ...]
    violation: str | None
    wall_seconds: float

    @property
    def ok(self) -> bool:
        """Safe, nothing stalled, no wait past the bound, something done."""
        return (
            self.violation is None
            and self.stalls == 0
            and self.max_wait <= self.wait_bound
            and self.tasks_done > 0
        )


def replay_command(seed: int, off: Sequence[str] = (), kind: str = "one-way") -> str:
    """The command that replays ``seed`` (of the same kind, with the same rules off)."""
    return " ".join(
        [
            "python -m tests.soak.floors",
            *([f"--kind {kind}"] if kind != "one-way" else []),
            f"--seed {seed}",
            *(f"--off {rule}" for rule in off),
        ]
    )


def run_floor_seed(seed: int, off: Sequence[str] = (), kind: str = "one-way") -> FloorResult:
    """Run seed ``seed`` of ``kind`` with the rules in ``off`` switched off."""
    draw, drive = KINDS[kind]
    run = draw(random.Random(seed))
    started = time.perf_counter()
    vehicle = {rule: RULES[rule] for rule in off if rule in RULES}
    options: dict[str, Any] = {"vehicle": vehicle_with(**vehicle)} if vehicle else {}
    options.update({rule: FLEET_RULES[rule] for rule in off if rule in FLEET_RULES})
    try:
        fleet = drive(run, **options)
    except SafetyError as violation:
        return FloorResult(
            seed, run, 0, 0, 0, 0, 0, 0.0, 0.0, (), str(violation), time.perf_counter() - started
        )
    figures = fleet.summary()
    now, watch = fleet.net.now, fleet.stalls
    standing = tuple(
        (agv_id, agv.phase, agv.point)
        for agv_id, agv in sorted(fleet.agvs.items())
        if watch.stalled_for(agv_id, now) > watch.limit_s
    )
    return FloorResult(
        seed,
        run,
        int(figures["tasks_completed"]),
        int(figures["deadlocks"]),
        int(figures["yields"]),
        int(figures["drive_ons"]),
        int(figures["detours"]),
        figures["max_wait"],
        figures["wait_bound"],
        standing,
        None,
        time.perf_counter() - started,
    )


def _describe(result: FloorResult) -> str:
    head = f"seed {result.seed}: {result.run}"
    if result.violation is not None:
        return f"{head}: {result.violation}"
    resorts = (
        f"{result.yields} yields, {result.drive_ons} drive-ons, {result.detours} detours, "
        f"the longest wait {result.max_wait:g} s of at most {result.wait_bound:g} s"
    )
    if result.stalls or result.max_wait > result.wait_bound:
        agvs = ", ".join(f"{a} ({phase} from {point})" for a, phase, point in result.standing)
        over = ", A WAIT PAST THE BOUND" if result.max_wait > result.wait_bound else ""
        return (
            f"{head}: {result.tasks_done} tasks done, {resorts}, {result.stalls} waits past "
            f"the stall limit{over}; standing at the end: {agvs or 'none'}"
        )
    return f"{head}: {result.tasks_done} tasks done, {resorts}"


def _share(result: FloorResult) -> float:
    return result.max_wait / result.wait_bound


def _worker(job: tuple[int, tuple[str, ...], str]) -> FloorResult:
    return run_floor_seed(*job)


def _run_many(seeds: list[int], off: tuple[str, ...], kind: str, jobs: int) -> int:
    started = time.perf_counter()
    failed: list[FloorResult] = []
    done = tasks = yields = drive_ons = detours = 0
    closest: FloorResult | None = None  # the run whose longest wait came nearest its bound
    with (
        seed_progress() as progress,
        multiprocessing.get_context("fork").Pool(jobs, maxtasksperchild=50) as pool,
    ):
        bar = progress.add_task("floors: 0 failed", total=len(seeds))
        for result in pool.imap_unordered(_worker, [(seed, off, kind) for seed in seeds]):
            done += 1
            tasks += result.tasks_done
            yields += result.yields
            drive_ons += result.drive_ons
            detours += result.detours
            if result.wait_bound and (closest is None or _share(result) > _share(closest)):
                closest = result
            if not result.ok:
                failed.append(result)
                progress.console.print(f"FAILED {_describe(result)}")
            progress.update(bar, advance=1, description=f"floors: {len(failed)} failed")
    rules = ", ".join(off) if off else "none"
    print(
        f"floors: {done} {kind} seeds run ({min(seeds)}-{max(seeds)} asked), rules off: {rules}, "
        f"{len(failed)} failed, {tasks} tasks done, {yields} yields, {drive_ons} drive-ons, "
        f"{detours} detours, {time.perf_counter() - started:.1f}s wall"
    )
    if closest is not None:
        print(
            f"the longest wait nearest its bound: seed {closest.seed}, {closest.max_wait:g} s "
            f"of at most {closest.wait_bound:g} s ({_share(closest):.0%})"
        )
    for result in sorted(failed, key=lambda r: r.seed):
        print(f"FAILED {_describe(result)}")
        print(f"  {replay_command(result.seed, off, kind)}")
    return 1 if failed else 0


def main(argv: list[str] | None = None) -> int:
    """The command line; returns the exit status."""
    parser = argparse.ArgumentParser(prog="python -m tests.soak.floors", description=__doc__)
    which = parser.add_mutually_exclusive_group(required=True)
    which.add_argument("--seed", type=int, help="replay one seed")
    which.add_argument("--seeds", type=parse_seeds, help="seeds to run, e.g. 0-299")
    parser.add_argument("--jobs", type=int, default=1, help="worker processes (default 1)")
    parser.add_argument(
        "--kind", choices=sorted(KINDS), default="one-way", help="the floors to draw"
    )
    parser.add_argument(
        "--off",
        action="append",
        default=[],
        choices=sorted(RULES.keys() | FLEET_RULES.keys()),
        help="run without this rule (may be given more than once)",
    )
    args = parser.parse_args(argv)
    off = tuple(dict.fromkeys(args.off))
    if args.seed is not None:
        result = run_floor_seed(args.seed, off, args.kind)
        print(f"{_describe(result)} ({result.wall_seconds:.1f}s wall)")
        if result.ok:
            return 0
        print(f"  {replay_command(result.seed, off, args.kind)}")
        return 1
    return _run_many(args.seeds, off, args.kind, max(1, args.jobs))


if __name__ == "__main__":
    sys.exit(main())
