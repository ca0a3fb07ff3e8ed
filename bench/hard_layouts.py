"""Hard layouts: floors drawn by hand that make AGVs wait long, against the wait bound.

Four floors a plant engineer draws (``agv_app.layout.shapes``), written to
``bench/layouts/<name>.json`` so that ``objectplaces sim --layout`` runs them as this
does:

* ``crossing``: two two-way lanes crossing at one point, four 15 m arms, at each arm's
  end a station spur and two parking spurs 4 m further;
* ``lane-between-areas``: one 40 m two-way lane between two dead-end areas, each with a
  pick-and-drop station and two parking spots;
* ``halls``: two one-way halls (20 m by 10 m, two stations and five parking spots
  each) joined by one 20 m two-way lane, the door;
* ``lay-by``: a 60 m two-way lane between two such areas, with a 14 m lay-by halfway.

Each runs, at load 0.7 (of what the fleet and the floor carry, the less;
:mod:`agv_app.tasks.load`) with the default settings, the largest fleet whose wait bound
(``agv_app.traffic.wait_bound``; docs/traffic.md, "Bounded waits") is at most 120 s,
and, with ``--fleets issue``, the fleets of issue 41 (8, 4, 10 and 4 AGVs); every seed
twice, with the AGVs' protocol and with the central baseline (``--traffic central``),
on the same layout, task stream and seed. The goals (issue 41), on the protocol's runs
of each floor: 0 collisions and 0 lock overlaps; no wait over 120 s and the bound no
looser than that; every wait within the bound; the task lead time (creation to
delivery, time at the task desk included) within 3x the task's free-flow lead time
(the same task in the free-flow replay) at the 95th percentile; throughput at least
the central baseline's on every seed and at least half the free-flow bound.

    python -m bench.hard_layouts [--seeds 1,2,3,4,5] [--minutes 30] [--load 0.7]
                                 [--fleets bounded|issue] [--wait-limit S] [--jobs 2]
"""

from __future__ import annotations

import argparse
import os
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from pathlib import Path

from agv_app.fleet import Fleet, FleetConfig
from agv_app.layout.graph import Layout
from agv_app.layout.json_format import load_layout, save_layout
from agv_app.layout.shapes import crossing, halls, lane_between_areas, lay_by
from agv_app.tasks import check_load
from bench.report import markdown_table, publish

__all__ = ["HARD_LAYOUTS", "Goal", "HardLayout", "goals", "main", "run_one"]

LAYOUTS_DIR = Path(__file__).resolve().parent / "layouts"
MODES = ("protocol", "central")
WAIT_LIMIT_S = 120.0
LEAD_RATIO_GOAL = 3.0
FREE_FLOW_SHARE_GOAL = 0.5


@dataclass(frozen=True, slots=True)
class HardLayout:
    """A named hard layout and the fleet issue 41 ran on it."""

    name: str
    build: Callable[[], Layout]
    issue_agvs: int

    @property
    def path(self) -> Path:
        """Where the layout file is written."""
        return LAYOUTS_DIR / f"{self.name}.json"


HARD_LAYOUTS = (
    HardLayout("crossing", crossing, 8),
    HardLayout("lane-between-areas", lane_between_areas, 4),
    HardLayout("halls", lambda: halls(parking=(5, 5)), 10),
    HardLayout("lay-by", lay_by, 4),
)
"""The named set, in the order the tables list it."""


def _layout(name: str) -> Layout:
    return load_layout(LAYOUTS_DIR / f"{name}.json")


def bounded_fleet(hard: HardLayout, limit_s: float = WAIT_LIMIT_S) -> int:
    """The largest fleet whose wait bound on ``hard`` is at most ``limit_s`` (at least
    one AGV)."""
    fleet = Fleet(_layout(hard.name), FleetConfig(agvs=1, seed=1))
    return max(1, fleet.wait_bound.fleet_within(limit_s))


def run_one(
    name: str,
    agvs: int,
    seed: int,
    traffic: str,
    minutes: float,
    load: float,
    wait_limit: float | None = None,
) -> dict[str, float]:
    """Run one fleet on the hard layout ``name`` and return its figures."""
    config = FleetConfig(agvs=agvs, seed=seed, load=load, traffic=traffic, wait_limit=wait_limit)
    fleet = Fleet(_layout(name), config)
    started = time.process_time()
    fleet.run(minutes * 60)
    figures = fleet.summary(time.process_time() - started)
    interval = fleet.task_interval
    figures["asked_per_hour"] = 0.0 if interval is None else 3600.0 / interval
    figures["in_service"] = fleet.active
    return figures


@dataclass(frozen=True, slots=True)
class Goal:
    """One goal on one layout, what was measured and whether it was met."""

    layout: str
    name: str
    measured: str
    met: bool


def goals(name: str, runs: dict[tuple[int, str], dict[str, float]], seeds: list[int]) -> list[Goal]:
    """Check the goals on the protocol's runs of layout ``name``."""
    ours = [runs[(s, "protocol")] for s in seeds]
    theirs = [runs[(s, "central")] for s in seeds]
    out = []
    unsafe = sum(r["collisions"] + r["lock_overlaps"] for r in ours)
    out.append(Goal(name, "0 collisions, 0 lock overlaps", f"{unsafe:g}", unsafe == 0))
    worst = max(r["max_wait"] for r in ours)
    bound = ours[0]["wait_bound"]
    out.append(
        Goal(
            name,
            f"no wait over {WAIT_LIMIT_S:g} s, the bound at most that",
            f"longest {worst:g} s, bound {bound:g} s",
            worst <= WAIT_LIMIT_S and bound <= WAIT_LIMIT_S,
        )
    )
    within = sum(r["max_wait"] <= r["wait_bound"] for r in ours)
    out.append(
        Goal(
            name,
            "every wait within the bound",
            f"{within} of {len(seeds)} runs",
            within == len(seeds),
        )
    )
    lead = max(r["lead_ratio_p95"] for r in ours)
    out.append(
        Goal(
            name,
            f"lead time p95 within {LEAD_RATIO_GOAL:g}x free flow",
            f"{lead:.2f}x worst seed",
            lead <= LEAD_RATIO_GOAL,
        )
    )
    wins = sum(
        a["tasks_per_hour"] >= b["tasks_per_hour"] for a, b in zip(ours, theirs, strict=True)
    )
    mean_ours = sum(r["tasks_per_hour"] for r in ours) / len(seeds)
    mean_theirs = sum(r["tasks_per_hour"] for r in theirs) / len(seeds)
    out.append(
        Goal(
            name,
            "throughput >= the central baseline's",
            f"{mean_ours:.1f} against {mean_theirs:.1f} tasks/h; as high on {wins} of "
            f"{len(seeds)} seeds",
            wins == len(seeds),
        )
    )
    shares = [r["tasks_per_hour"] / max(r["free_flow_tasks_per_hour"], 1e-9) for r in ours]
    out.append(
        Goal(
            name,
            f"throughput >= {FREE_FLOW_SHARE_GOAL:.0%} of free flow",
            f"{min(shares):.0%} worst seed",
            min(shares) >= FREE_FLOW_SHARE_GOAL,
        )
    )
    return out


def _row(name: str, agvs: int, seed: int, mode: str, r: dict[str, float]) -> list[object]:
    share = r["tasks_per_hour"] / max(r["free_flow_tasks_per_hour"], 1e-9)
    return [
        name,
        agvs if r["in_service"] == agvs else f"{r['in_service']:g} of {agvs}",
        seed,
        mode,
        f"{r['tasks_completed']:g} of {r['tasks_created']:g}",
        round(r["asked_per_hour"], 1),
        r["tasks_per_hour"],
        r["free_flow_tasks_per_hour"],
        f"{share:.0%}",
        r["lead_ratio_p95"],
        r["collisions"],
        r["lock_overlaps"],
        r["stalls_60s"],
        r["max_wait"],
        r["wait_bound"],
        f"{r['yields']:g}/{r['drive_ons']:g}/{r['detours']:g}",
    ]


def main(argv: list[str] | None = None) -> None:
    """Run the benchmark and publish its section of BENCHMARKS.md."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seeds", default="1,2,3,4,5")
    parser.add_argument("--minutes", type=float, default=30.0, help="simulated minutes per run")
    parser.add_argument(
        "--load", type=float, default=0.7, help="share of what the fleet and floor carry, (0, 1]"
    )
    parser.add_argument(
        "--fleets",
        choices=("bounded", "issue"),
        default="bounded",
        help="bounded: the largest fleet whose wait bound is at most 120 s; issue: the "
        "fleets of issue 41",
    )
    parser.add_argument(
        "--wait-limit",
        type=float,
        default=None,
        help="FleetConfig.wait_limit: only the largest fleet whose bound is within it takes "
        "tasks (default: none)",
    )
    parser.add_argument(
        "--jobs", type=int, default=min(2, os.cpu_count() or 1), help="runs in parallel"
    )
    args = parser.parse_args(argv)
    try:
        check_load(args.load)
    except ValueError as exc:
        raise SystemExit(f"bench.hard_layouts: --load: {exc}") from exc
    seeds = [int(s) for s in args.seeds.split(",") if s]
    LAYOUTS_DIR.mkdir(exist_ok=True)
    for hard in HARD_LAYOUTS:
        save_layout(hard.build(), hard.path)
    fleets = {
        h.name: bounded_fleet(h) if args.fleets == "bounded" else h.issue_agvs for h in HARD_LAYOUTS
    }
    runs: dict[str, dict[tuple[int, str], dict[str, float]]] = {h.name: {} for h in HARD_LAYOUTS}
    with ProcessPoolExecutor(max_workers=args.jobs) as pool:
        futures = {
            pool.submit(
                run_one,
                h.name,
                fleets[h.name],
                seed,
                mode,
                args.minutes,
                args.load,
                args.wait_limit,
            ): (
                h.name,
                seed,
                mode,
            )
            for h in HARD_LAYOUTS
            for seed in seeds
            for mode in MODES
        }
        for future in as_completed(futures):
            name, seed, mode = futures[future]
            runs[name][(seed, mode)] = future.result()
            print(f"{name} seed {seed} {mode}: done", flush=True)
    _publish(args, seeds, fleets, runs)


def _publish(
    args: argparse.Namespace,
    seeds: list[int],
    fleets: dict[str, int],
    runs: dict[str, dict[tuple[int, str], dict[str, float]]],
) -> None:
    header = [
        "layout",
        "AGVs (in service)",
        "seed",
        "traffic",
        "tasks done",
        "tasks asked/h",
        "tasks/h",
        "free-flow tasks/h",
        "of free flow",
        "lead time p95, x free flow",
        "collisions",
        "lock overlaps",
        "waits > 60 s",
        "longest wait, s",
        "wait bound, s",
        "yields/drive-ons/detours",
    ]
    rows = [
        _row(h.name, fleets[h.name], seed, mode, runs[h.name][(seed, mode)])
        for h in HARD_LAYOUTS
        for seed in seeds
        for mode in MODES
    ]
    checked = [g for h in HARD_LAYOUTS for g in goals(h.name, runs[h.name], seeds)]
    goal_rows = [[g.layout, g.name, g.measured, "yes" if g.met else "**no**"] for g in checked]
    limited = "" if args.wait_limit is None else f" --wait-limit {args.wait_limit:g}"
    which = (
        "the largest fleet whose wait bound is at most 120 s"
        if args.fleets == "bounded"
        else "the fleets of issue 41"
    )
    body = (
        f"Each hard layout (`bench/layouts/`, drawn by `agv_app.layout.shapes`) with {which}, "
        f"load {args.load:g} (of what the fleet and the floor carry, the less: "
        '"Load" in docs/fleet.md; tasks asked/h is the rate it sets), '
        f"{args.minutes:g} simulated minutes per run, seeds {args.seeds}, "
        "the default settings (the task desk's limit as `objectplaces sim` sets it). Each "
        "seed runs twice on the same layout, task stream and seed: `protocol` is the AGVs' "
        "own traffic protocol, `central` the baseline (one first-come-first-served "
        "scheduler, no network). Lead time: creation to delivery, time at the task desk "
        "included, over the same task's in the free-flow replay, 95th percentile of the "
        'tasks delivered. Wait bound: docs/traffic.md, "Bounded waits". One run, e.g.: '
        f"`objectplaces sim --layout bench/layouts/crossing.json --agvs "
        f"{fleets['crossing']} --load {args.load:g} --minutes {args.minutes:g} --seed 1"
        f"{limited}`."
        "\n\n"
        + markdown_table(header, rows)
        + "\n\nGoals (issue 41), on the protocol's runs:\n\n"
        + markdown_table(["layout", "goal", "measured", "met"], goal_rows)
    )
    command = (
        f".venv/bin/python -m bench.hard_layouts --seeds {args.seeds} --minutes {args.minutes:g} "
        f"--load {args.load:g} --fleets {args.fleets}{limited}"
    )
    title = (
        "Hard layouts: waits within the bound"
        if args.fleets == "bounded"
        else "Hard layouts: the fleets of issue 41"
    )
    if args.wait_limit is not None:
        title += f", waits limited to {args.wait_limit:g} s"
        body = (
            f"With `--wait-limit {args.wait_limit:g}` (`FleetConfig.wait_limit`): only the "
            "largest fleet whose wait bound is within it takes tasks, the others stay "
            "parked as a reserve; the bound counts the AGVs in service.\n\n" + body
        )
    key = f"hard_layouts_{args.fleets}" + ("" if args.wait_limit is None else "_limited")
    publish(key, title, body, command)


if __name__ == "__main__":
    main()
