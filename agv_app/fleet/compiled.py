"""The fleet simulation's compiled build: which modules mypyc compiles.

The modules a simulated fleet spends its time in (docs/sim-speed.md, "A compiled
build"): the node's core, the in-memory network and its event loop, the tuplespace,
and the AGVs' driving, voting and geometry. ``objectplaces sim --compiled`` and
``bench/sim_speed.py --compiled`` run on this build.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Final

from objectplaces.compiled import (
    ACTIVE_ENV,
    Build,
    CompiledBuildError,
    ensure_built,
    loaded_compiled,
    run_on_build,
)

__all__ = ["SIM_MODULES", "compiled_report", "run_compiled", "sim_build"]

SIM_MODULES: Final = (
    "tuplespace._match",
    "tuplespace._space",
    "objectplaces.activator",
    "objectplaces.core.bindings",
    "objectplaces.core.channel",
    "objectplaces.core.channels",
    "objectplaces.core.codec",
    "objectplaces.core.config",
    "objectplaces.core.events",
    "objectplaces.core.group_json",
    "objectplaces.core.groups",
    "objectplaces.core.ids",
    "objectplaces.core.intake",
    "objectplaces.core.introspection",
    "objectplaces.core.liveness",
    "objectplaces.core.messages",
    "objectplaces.core.node",
    "objectplaces.core.observers",
    "objectplaces.core.outbox",
    "objectplaces.core.own",
    "objectplaces.core.participations",
    "objectplaces.core.plumbing",
    "objectplaces.core.rest",
    "objectplaces.core.roles",
    "objectplaces.core.session_state",
    "objectplaces.core.sessions",
    "objectplaces.core.spatial",
    "objectplaces.core.timers",
    "objectplaces.core.values",
    "objectplaces.core.view",
    "objectplaces.core.view_index",
    "objectplaces.runtime.pump",
    "objectplaces.runtime.sim",
    "objectplaces.sim",
    "objectplaces.transport.memory",
    "agv_app.fleet.charge_rule",
    "agv_app.fleet.chargers",
    "agv_app.fleet.metrics",
    "agv_app.fleet.stalls",
    "agv_app.geometry.area",
    "agv_app.geometry.polyline",
    "agv_app.geometry.probe",
    "agv_app.geometry.projection",
    "agv_app.geometry.wire",
    "agv_app.layout.blocked",
    "agv_app.layout.elements",
    "agv_app.layout.graph",
    "agv_app.layout.plan",
    "agv_app.layout.search",
    "agv_app.protocol",
    "agv_app.tasks.auction",
    "agv_app.tasks.book",
    "agv_app.tasks.custody_watch",
    "agv_app.tasks.desk",
    "agv_app.tasks.limits",
    "agv_app.tasks.station",
    "agv_app.tasks.stations",
    "agv_app.traffic.central",
    "agv_app.traffic.collision",
    "agv_app.traffic.collision_groups",
    "agv_app.traffic.deadlock",
    "agv_app.traffic.floor_features",
    "agv_app.traffic.lockbook",
    "agv_app.traffic.monitor",
    "agv_app.traffic.reach",
    "agv_app.traffic.request_wire",
    "agv_app.traffic.requester",
    "agv_app.traffic.stale_relay",
    "agv_app.traffic.vote",
    "agv_app.traffic.voter",
    "agv_app.vehicle.battery",
    "agv_app.vehicle.binding",
    "agv_app.vehicle.closures",
    "agv_app.vehicle.config",
    "agv_app.vehicle.controller",
    "agv_app.vehicle.driven",
    "agv_app.vehicle.driver",
    "agv_app.vehicle.errands",
    "agv_app.vehicle.kinematics",
    "agv_app.vehicle.last_resort",
    "agv_app.vehicle.locking",
    "agv_app.vehicle.operations",
    "agv_app.vehicle.publication",
    "agv_app.vehicle.routing",
    "agv_app.vehicle.sim_driver",
)
"""The modules compiled, by dotted name."""

_PACKAGES: Final = ("tuplespace", "objectplaces", "agv_app", "dashboard", "static")


def sim_build() -> Build:
    """The build of the packages as this process found them."""
    return Build(Path(__file__).resolve().parents[2], _PACKAGES, SIM_MODULES)


def run_compiled(command_line: Sequence[str]) -> int:
    """Run ``objectplaces COMMAND_LINE`` on the compiled build, building it first if
    the cache has none for this source (a minute or two, with lines on standard error).

    Returns:
        The run's exit status; 1 when the build could not be made.
    """
    from rich.console import Console

    console = Console(stderr=True)
    try:
        with console.status("compiling the simulation's modules with mypyc"):
            # Plain text: a cache path may hold brackets that rich would read as markup.
            tree = ensure_built(
                sim_build(), report=lambda line: console.print(line, markup=False, highlight=False)
            )
    except CompiledBuildError as exc:
        print(f"objectplaces sim: --compiled: {exc}", file=sys.stderr)
        print(
            "objectplaces sim: run without --compiled for the same run from the source",
            file=sys.stderr,
        )
        return 1
    return run_on_build(tree, command_line)


def compiled_report() -> str | None:
    """A line on how much of this process runs compiled, in a process started on a
    build; None in any other process."""
    tree = os.environ.get(ACTIVE_ENV)
    if not tree:
        return None
    loaded = loaded_compiled(SIM_MODULES)
    return f"compiled: {len(loaded)} of {len(SIM_MODULES)} modules from {tree}"


def main() -> int:
    """Make the simulation's build for this source, if the cache has none, saying how it
    goes; ``make test`` runs this before the suite. Exit status 1 when it cannot be made.
    """
    try:
        tree = ensure_built(sim_build(), report=lambda line: print(line, flush=True))
    except CompiledBuildError as exc:
        print(f"agv_app.fleet.compiled: {exc}", file=sys.stderr)
        return 1
    print(f"compiled build: {tree}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
