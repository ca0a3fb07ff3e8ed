"""The fleet ``objectplaces demo`` shows: :func:`demo_source`."""

from __future__ import annotations

import argparse
from typing import Any

from agv_app.fleet.mesh import MeshFleet
from agv_app.fleet.sim import Fleet, FleetConfig
from agv_app.layout.demo import DEMO_VEHICLE_LENGTH_M, DEMO_VEHICLE_WIDTH_M, demo_warehouse
from agv_app.tasks.admission import CROWDED
from agv_app.tasks.load import (
    DEFAULT_LOAD,
    check_load,
    fleet_floor_rules,
    floor_vehicles,
    initial_tasks,
    task_interval_for_load,
)
from agv_app.vehicle.config import AgvConfig
from agv_app.vehicle.kinematics import VehicleSpec

__all__ = ["DEMO_AGVS", "demo_source"]

DEMO_AGVS = 12
"""AGVs of the simulated demo fleet by default."""


def demo_source(
    args: argparse.Namespace | None = None,
    *,
    agvs: int | None = None,
    seed: int | None = None,
    processes: int = 0,
    load: float | None = None,
    vda5050: str | None = None,
    vda5050_credentials: Any = None,
    transport: str = "websocket",
    max_open_tasks: int | str | None = CROWDED,
) -> Fleet | MeshFleet:
    """The fleet ``objectplaces demo`` shows: the demo warehouse, tasks arriving for ever.

    Accepts the parsed ``demo`` arguments or the keywords ``agvs``, ``seed``,
    ``processes`` and ``load``: 0 processes simulates ``agvs`` AGVs on one network in
    this process; more runs that many AGV processes on the WebSocket mesh (a
    :class:`~agv_app.fleet.mesh.MeshFleet`, which the caller must ``await start()`` and
    ``await stop()``). Either way tasks arrive at the rate that keeps ``load`` of the
    AGVs busy (default :data:`~agv_app.tasks.load.DEFAULT_LOAD`), and about ``load``
    times the AGVs get a task at the start, so most of them move within seconds.

    With ``vda5050`` (``mqtts://HOST:PORT``) every AGV speaks VDA 5050 over that broker
    (an :class:`~agv_app.vda5050.sim_fleet.VdaSimFleet` in this process, or with
    ``processes`` each AGV process its own client) with its certificate from
    ``vda5050_credentials`` (an :class:`~agv_app.vda5050.link.VdaCredentials`), and no
    task arrives by itself: the master control sends orders (docs/vda5050.md).

    ``max_open_tasks`` keeps at most that many tasks on the floor; the others wait at
    the task desk (:class:`~agv_app.tasks.desk.TaskDesk`; ``"auto"``: a limit that
    follows the floor's long waits; None: no limit; the default,
    :data:`~agv_app.tasks.admission.CROWDED`: ``"auto"`` for a fleet larger than its
    floor carries, else none).

    Raises:
        ValueError: ``processes`` is negative or more than the layout can park, or
            ``load`` is not in (0, 1].
    """
    if args is not None:
        agvs = getattr(args, "agvs", agvs)
        seed = getattr(args, "seed", seed)
        processes = getattr(args, "processes", processes) or 0
        load = getattr(args, "load", load)
        vda5050 = getattr(args, "vda5050", vda5050)
        vda5050_credentials = getattr(args, "vda5050_credentials", vda5050_credentials)
        transport = getattr(args, "transport", transport)
        max_open_tasks = getattr(args, "max_open_tasks", max_open_tasks)
    load = check_load(DEFAULT_LOAD if load is None else load)
    seed = 1 if seed is None else seed
    if processes < 0:
        raise ValueError(f"processes must be 0 or more, got {processes!r}")
    if vda5050 is not None and processes:
        return MeshFleet(
            agvs=processes,
            seed=seed,
            task_interval=None,
            vda5050=vda5050,
            vda5050_credentials=vda5050_credentials,
        )
    if vda5050 is not None:
        # Imported here: agv_app.vda5050 builds on this package's simulated fleet.
        from agv_app.vda5050.sim_fleet import VdaSimFleet

        return VdaSimFleet(
            agvs=agvs or DEMO_AGVS,
            seed=seed,
            vda5050=vda5050,
            credentials=vda5050_credentials,
        )
    if processes:
        layout = demo_warehouse()
        spec = VehicleSpec(DEMO_VEHICLE_LENGTH_M, DEMO_VEHICLE_WIDTH_M)
        dwell = 5.0
        rules = fleet_floor_rules(spec, t_update=AgvConfig().t_update)
        speed = spec.max_speed_m_s
        floor = floor_vehicles(layout, speed_m_s=speed, dwell_s=dwell, rules=rules)
        return MeshFleet(
            agvs=processes,
            seed=seed,
            layout=layout,
            task_interval=task_interval_for_load(
                layout, agvs=processes, load=load, speed_m_s=speed, dwell_s=dwell, floor=floor
            ),
            start_tasks=initial_tasks(agvs=processes, load=load, floor=floor),
            dwell=dwell,
            transport=transport,
            max_open_tasks=max_open_tasks,
        )
    config = FleetConfig(
        agvs=agvs or DEMO_AGVS, seed=seed, load=load, max_open_tasks=max_open_tasks
    )
    return Fleet(demo_warehouse(), config)
