"""The fleet ``objectplaces demo`` shows: :func:`demo_source`."""

from __future__ import annotations

import argparse

from agv_app.fleet.mesh import MeshFleet
from agv_app.fleet.sim import Fleet, FleetConfig
from agv_app.layout.demo import demo_warehouse

__all__ = ["MESH_DEMO_TASK_INTERVAL_S", "demo_source"]

MESH_DEMO_TASK_INTERVAL_S = 90.0
"""Mean seconds between tasks for one AGV process of the mesh demo (divided by N)."""


def demo_source(
    args: argparse.Namespace | None = None,
    *,
    agvs: int | None = None,
    seed: int | None = None,
    processes: int = 0,
) -> Fleet | MeshFleet:
    """The fleet ``objectplaces demo`` shows: the demo warehouse, tasks arriving for ever.

    Accepts the parsed ``demo`` arguments or the keywords ``agvs``, ``seed`` and
    ``processes``: 0 simulates ``agvs`` AGVs on one network in this process; more runs
    that many AGV processes on the WebSocket mesh (a :class:`~agv_app.fleet.mesh.MeshFleet`,
    which the caller must ``await start()`` and ``await stop()``).

    Raises:
        ValueError: ``processes`` is negative or more than the layout can park.
    """
    if args is not None:
        agvs = getattr(args, "agvs", agvs)
        seed = getattr(args, "seed", seed)
        processes = getattr(args, "processes", processes) or 0
    if processes < 0:
        raise ValueError(f"processes must be 0 or more, got {processes!r}")
    if processes:
        return MeshFleet(
            agvs=processes,
            seed=1 if seed is None else seed,
            task_interval=MESH_DEMO_TASK_INTERVAL_S / processes,
        )
    return Fleet(demo_warehouse(), FleetConfig(agvs=agvs or 12, seed=1 if seed is None else seed))
