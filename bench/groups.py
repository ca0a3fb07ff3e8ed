"""Group maintenance at scale: scoped dissemination + indexed definitions vs the paper's
full multicast + an opaque callable.

N nodes random-walk at 1 m/s over a square sized so each hears about 8 others inside
its interest radius; each publishes its position once per simulated second and runs one
collision-avoidance-style session (circles_overlap, hull length 2.5 m) whose participants
answer once. Figures: CPU seconds per simulated second, deliveries and bytes per update.

Run: .venv/bin/python bench/groups.py [--sizes 100,1000,10000] [--seconds 5] [--against DIR]

``--against DIR`` runs every configuration a second time with the checkout in ``DIR``,
alternating with this tree's, and adds a table of both trees' CPU cost.
"""

from __future__ import annotations

import argparse
import math
import random
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from rich.progress import Progress

from bench.elsewhere import call_in_tree
from bench.report import markdown_table, publish
from objectplaces import Initiator, Participant, ParticipantRef, groups
from objectplaces.sim import SimulatedNetwork

INTEREST_RADIUS = 10.0
HULL_LENGTH = 2.5
NEIGHBOURS = 8
SPEED_M_S = 1.0


class Requester(Initiator):
    """Keeps a session open and counts its members' answers."""

    answers = 0

    def in_group(self, participant: ParticipantRef) -> None:
        self.send(participant, b"request")

    def receive(self, participant: ParticipantRef, message: Any) -> None:
        Requester.answers += 1


class Voter(Participant):
    """Answers every request once."""

    def receive(self, message: Any) -> None:
        self.send(b"allow")


def opaque_circles_overlap(mine: Any, theirs: Any) -> bool:
    """The same predicate as ``groups.circles_overlap()``, hidden from the index."""
    (x1, y1), (x2, y2) = mine["position"], theirs["position"]
    reach: float = mine["hull_length"] + theirs["hull_length"]
    return math.hypot(x1 - x2, y1 - y2) <= reach


@dataclass
class Result:
    """One measured configuration."""

    nodes: int
    mode: str
    cpu_per_sim_s: float
    deliveries_per_update: float
    bytes_per_update: float
    answers: int


def run(n: int, scoped: bool, seconds: float, seed: int = 1) -> Result:
    """Build, warm up, then measure ``seconds`` of simulated time."""
    rng = random.Random(seed)
    side = math.sqrt(n * math.pi * INTEREST_RADIUS**2 / NEIGHBOURS)
    net = SimulatedNetwork(seed=seed, delay=0.002, cell_size=INTEREST_RADIUS / 4)
    radius = INTEREST_RADIUS if scoped else None
    definition = groups.circles_overlap() if scoped else opaque_circles_overlap
    names = [f"n{i}" for i in range(n)]
    pos = {name: [rng.uniform(0, side), rng.uniform(0, side)] for name in names}
    heading = {name: rng.uniform(0, 2 * math.pi) for name in names}
    nodes = {name: net.add_node(name, interest_radius=radius) for name in names}
    for name, node in nodes.items():
        node.set_participant_factory("voter", Voter)
        node.update_node_property("position", tuple(pos[name]))
        node.update_node_property("hull_length", HULL_LENGTH)
    net.run_for(0.5)
    for node in nodes.values():
        node.start_interaction(Requester(), definition, "voter")

    def move(name: str) -> None:
        heading[name] += rng.uniform(-0.5, 0.5)
        p = pos[name]
        p[0] = min(side, max(0.0, p[0] + SPEED_M_S * math.cos(heading[name])))
        p[1] = min(side, max(0.0, p[1] + SPEED_M_S * math.sin(heading[name])))
        nodes[name].update_node_property("position", (p[0], p[1]))
        net.loop.call_at(net.now + 1.0, move, name)

    for name in names:
        net.loop.call_at(net.now + rng.random(), move, name)
    net.run_for(1.0)
    before = net.stats()
    Requester.answers = 0
    start = time.process_time()
    net.run_for(seconds)
    cpu = time.process_time() - start
    after = net.stats()
    updates = n * seconds
    deliveries = after.by_kind["property"][0] - before.by_kind["property"][0]
    size = after.by_kind["property"][1] - before.by_kind["property"][1]
    return Result(
        n,
        "scoped + indexed" if scoped else "full multicast + opaque",
        cpu / seconds,
        deliveries / updates,
        size / updates,
        Requester.answers,
    )


def main() -> None:
    """Measure every configuration and publish the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="100,1000,10000")
    parser.add_argument("--seconds", type=float, default=5.0)
    parser.add_argument(
        "--full-up-to",
        type=int,
        default=1000,
        help="largest N also run with full multicast (it costs O(N^2))",
    )
    parser.add_argument(
        "--against", type=Path, help="also run every configuration with this checkout"
    )
    args = parser.parse_args()
    sizes = [int(s) for s in args.sizes.split(",")]
    plan = [(n, True) for n in sizes] + [(n, False) for n in sizes if n <= args.full_up_to]
    results: list[Result] = []
    baseline: list[Result] = []
    with Progress(transient=True) as progress:
        task = progress.add_task("configurations", total=len(plan))
        for n, scoped in plan:
            progress.update(task, description=f"N={n} {'scoped' if scoped else 'full'}")
            results.append(run(n, scoped, args.seconds))
            if args.against:
                figures = call_in_tree(
                    args.against, "bench.groups", "run", [n, scoped, args.seconds]
                )
                baseline.append(Result(**figures))
            progress.advance(task)
    rows = []
    by_key = {(r.nodes, r.mode.startswith("scoped")): r for r in results}
    for r in sorted(results, key=lambda r: (r.nodes, r.mode)):
        full = by_key.get((r.nodes, False))
        ratio = (
            f"{full.cpu_per_sim_s / r.cpu_per_sim_s:.1f}x"
            if full and r.mode.startswith("scoped")
            else ""
        )
        rows.append(
            [
                r.nodes,
                r.mode,
                f"{r.cpu_per_sim_s:.3f}",
                ratio,
                f"{r.deliveries_per_update:.1f}",
                f"{r.bytes_per_update:.0f}",
                r.answers,
            ]
        )
    body = (
        f"{args.seconds:g} simulated seconds per configuration after warm-up; about "
        f"{NEIGHBOURS} nodes within each node's {INTEREST_RADIUS:g} m interest radius; one "
        "position update per node per second; one circles_overlap session per node.\n\n"
        + markdown_table(
            [
                "N",
                "dissemination + definition",
                "CPU s per sim s",
                "cheaper than full",
                "deliveries per update",
                "wire bytes per update",
                "answers received",
            ],
            rows,
        )
        + "\n\nGoals: 10,000 nodes at <= 1 CPU s per simulated s with scoped + indexed; "
        "scoped + indexed >= 20x cheaper than full + opaque at 1,000 nodes."
    )
    command = f".venv/bin/python bench/groups.py --sizes {args.sizes} --seconds {args.seconds:g}"
    if args.against:
        body += "\n\n" + _comparison(results, baseline, args.against)
        command += f" --against {args.against}"
    publish("groups", "Group maintenance at scale (bench/groups.py)", body, command)


def _comparison(results: list[Result], baseline: list[Result], against: Path) -> str:
    """The table of this tree's CPU cost beside the other checkout's, same run."""
    rows = [
        [
            r.nodes,
            r.mode,
            f"{r.cpu_per_sim_s:.3f}",
            f"{b.cpu_per_sim_s:.3f}",
            f"{r.cpu_per_sim_s / b.cpu_per_sim_s:.2f}",
            f"{r.bytes_per_update:.0f} / {b.bytes_per_update:.0f}",
        ]
        for r, b in zip(results, baseline, strict=True)
    ]
    return f"Against the checkout in `{against}`, measured in the same run, alternating:\n\n" + (
        markdown_table(
            [
                "N",
                "dissemination + definition",
                "CPU s per sim s, this",
                f"CPU s per sim s, {against.name}",
                "this / against",
                "wire bytes per update (this / against)",
            ],
            rows,
        )
    )


if __name__ == "__main__":
    main()
