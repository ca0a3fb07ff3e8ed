"""Batteries and charging benchmark: the fleet's throughput with batteries against without.

Two runs of the same simulated fleet (same seed, same tasks arriving) on the demo
warehouse: one with no battery model, one where every AGV has the default battery
(``BatterySpec()``), drains as it drives and handles loads, and charges at the layout's
ten chargers. The shift starts with the batteries spread between ``100 - spread`` and
100 % (seeded), as a fleet in operation has them. The goal of issue 42: 0 violations,
0 vehicles run empty, and throughput (tasks delivered per hour, charging included) at
least 80 % of the run without batteries.

    python -m bench.battery [--agvs 20] [--load 0.7] [--hours 4] [--seed 1] [--spread 50]
"""

from __future__ import annotations

import argparse
import random
import sys
import time

from agv_app.fleet import Fleet, FleetConfig
from agv_app.fleet.chargers import Chargers
from agv_app.vehicle.battery import BatterySpec
from bench.report import markdown_table, publish

__all__ = ["GOAL_RATIO", "main", "run"]

GOAL_RATIO = 0.8
"""Throughput with batteries over throughput without, at least."""


def run(
    agvs: int, load: float, hours: float, seed: int, *, batteries: bool, spread: float = 50.0
) -> dict[str, float]:
    """One run of ``hours`` simulated hours; its summary (with the wall time)."""
    spec = BatterySpec() if batteries else None
    fleet = Fleet(config=FleetConfig(agvs=agvs, load=load, seed=seed, batteries=spec))
    if spec is not None:
        rng = random.Random(seed)
        levels = {a: 100.0 - rng.uniform(0.0, spread) for a in fleet.agvs}
        fleet.chargers = Chargers(spec, fleet.parking, fleet.agvs, levels=levels)
    started = time.perf_counter()
    every = 600.0
    done = 0.0
    while done < hours * 3600:
        step = min(every, hours * 3600 - done)
        fleet.run(step)
        done += step
        print(
            f"  {'with' if batteries else 'without'} batteries: {done / 3600:.2f} h simulated, "
            f"{time.perf_counter() - started:.0f} s wall",
            file=sys.stderr,
        )
    return fleet.summary(time.perf_counter() - started)


def main(argv: list[str] | None = None) -> int:
    """Run both, print and record the figures; exit 1 if a goal is missed."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--agvs", type=int, default=20)
    parser.add_argument("--load", type=float, default=0.7)
    parser.add_argument("--hours", type=float, default=4.0)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--spread", type=float, default=50.0)
    args = parser.parse_args(argv)
    command = (
        f"python -m bench.battery --agvs {args.agvs} --load {args.load} --hours {args.hours:g} "
        f"--seed {args.seed} --spread {args.spread:g}"
    )
    print(command, file=sys.stderr)
    base = run(args.agvs, args.load, args.hours, args.seed, batteries=False)
    charged = run(args.agvs, args.load, args.hours, args.seed, batteries=True, spread=args.spread)
    ratio = charged["tasks_per_hour"] / base["tasks_per_hour"] if base["tasks_per_hour"] else 0.0
    violations = {
        k: int(r["collisions"] + r["lock_overlaps"]) for k, r in (("base", base), ("bat", charged))
    }
    met = violations["bat"] == 0 and charged["ran_empty"] == 0 and ratio >= GOAL_RATIO
    header = [
        "run",
        "tasks/h",
        "tasks done",
        "violations",
        "deadlocks",
        "charges",
        "charging, AGV-h",
        "ran empty",
        "lowest charge, %",
        "longest wait for a charger, s",
        "sim speed",
    ]
    rows = [
        [
            "without batteries",
            base["tasks_per_hour"],
            int(base["tasks_completed"]),
            violations["base"],
            int(base["deadlocks"]),
            "-",
            "-",
            "-",
            "-",
            "-",
            base["sim_speed"],
        ],
        [
            "with batteries",
            charged["tasks_per_hour"],
            int(charged["tasks_completed"]),
            violations["bat"],
            int(charged["deadlocks"]),
            int(charged["charges"]),
            f"{charged['charging_seconds'] / 3600:.2f}",
            int(charged["ran_empty"]),
            charged["min_state_of_charge"],
            charged["max_charger_wait"],
            charged["sim_speed"],
        ],
    ]
    body = (
        f"Goal (issue 42): {args.agvs} AGVs, demo warehouse, load {args.load}, "
        f"{args.hours:g} simulated hours with batteries and charging: 0 violations, 0 vehicles "
        f"run empty, throughput >= {GOAL_RATIO:.0%} of the same run without batteries. "
        "Default battery (`BatterySpec()`: 0.01 %/m, 0.02 %/s of load handling, 0.001 %/s, "
        f"charging 0.05 %/s from below 25 % to 90 %), batteries at first spread over "
        f"{100 - args.spread:g}..100 %.\n\n"
        + markdown_table(header, rows)
        + f"\n\nThroughput with batteries: **{ratio:.1%}** of the run without "
        f"(goal {GOAL_RATIO:.0%}): {'met' if met else 'missed'}."
    )
    publish("battery", "Batteries and charging (bench/battery.py)", body, command)
    return 0 if met else 1


if __name__ == "__main__":
    raise SystemExit(main())
