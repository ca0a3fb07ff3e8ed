"""Fleet stop benchmark: from an operator's stop to every vehicle standing.

A simulated fleet on the demo warehouse runs at load; every few simulated minutes the
whole fleet is stopped (``Fleet.stop_vehicles``), the steps until every vehicle reports
speed 0 are counted, the fleet stands a while and is resumed. The goal of issue 42: every
vehicle standing within the largest braking time (top speed over deceleration) plus one
control step, with 0 collisions and 0 lock overlaps, and no vehicle moving while stopped.

    python -m bench.stop [--agvs 20] [--load 0.7] [--stops 8] [--every 180] [--seed 1]
"""

from __future__ import annotations

import argparse
import math

from agv_app.fleet import Fleet, FleetConfig
from bench.report import markdown_table, publish

__all__ = ["main", "run"]


def run(agvs: int, load: float, stops: int, every_s: float, seed: int) -> dict[str, float]:
    """Run the fleet, stop it ``stops`` times; the figures."""
    fleet = Fleet(config=FleetConfig(agvs=agvs, load=load, seed=seed, fail_on_violation=False))
    dt = fleet.config.dt
    spec = fleet.plan_spec
    bound_s = spec.max_speed_m_s / spec.max_accel_m_s2 + dt
    worst_s = 0.0
    moving_at_stop = 0
    moved_while_stopped = 0
    for _ in range(stops):
        fleet.run(every_s)
        moving_at_stop += sum(agv.vehicle.speed > 0.0 for agv in fleet.agvs.values())
        fleet.stop_vehicles()
        steps = 0
        while any(agv.vehicle.speed > 0.0 for agv in fleet.agvs.values()):
            fleet.step()
            steps += 1
            if steps * dt > 10 * bound_s:
                break
        worst_s = max(worst_s, steps * dt)
        poses = {a: agv.vehicle.pose() for a, agv in fleet.agvs.items()}
        fleet.run(30.0)
        moved_while_stopped += sum(agv.vehicle.pose() != poses[a] for a, agv in fleet.agvs.items())
        fleet.resume_vehicles()
    figures = fleet.summary()
    return {
        "bound_s": bound_s,
        "worst_s": worst_s,
        "moving_at_stop": float(moving_at_stop),
        "moved_while_stopped": float(moved_while_stopped),
        "collisions": figures["collisions"],
        "lock_overlaps": figures["lock_overlaps"],
        "tasks_completed": figures["tasks_completed"],
    }


def main(argv: list[str] | None = None) -> int:
    """Run, print and record the figures; exit 1 if a goal is missed."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--agvs", type=int, default=20)
    parser.add_argument("--load", type=float, default=0.7)
    parser.add_argument("--stops", type=int, default=8)
    parser.add_argument("--every", type=float, default=180.0)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args(argv)
    r = run(args.agvs, args.load, args.stops, args.every, args.seed)
    met = (
        r["worst_s"] <= r["bound_s"] + 1e-9
        and r["moved_while_stopped"] == 0
        and r["collisions"] == 0
        and r["lock_overlaps"] == 0
    )
    rows = [
        [
            args.agvs,
            args.load,
            args.stops,
            int(r["moving_at_stop"]),
            f"{r['worst_s']:.2f}",
            f"{r['bound_s']:.2f}",
            int(r["moved_while_stopped"]),
            int(r["collisions"]),
            int(r["lock_overlaps"]),
            int(r["tasks_completed"]),
            "yes" if met else "no",
        ]
    ]
    header = [
        "AGVs",
        "load",
        "stops",
        "moving at the stops",
        "stop to all standing, worst s",
        "goal: braking time + one step, s",
        "moved while stopped",
        "collisions",
        "lock overlaps",
        "tasks done",
        "met",
    ]
    command = (
        f"python -m bench.stop --agvs {args.agvs} --load {args.load} --stops {args.stops} "
        f"--every {args.every:g} --seed {args.seed}"
    )
    publish("stop", "Fleet stop (bench/stop.py)", markdown_table(header, rows), command)
    return 0 if met and math.isfinite(r["worst_s"]) else 1


if __name__ == "__main__":
    raise SystemExit(main())
