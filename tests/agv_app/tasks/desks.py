"""A task desk on the demo warehouse with every pick station open, and no fleet."""

from __future__ import annotations

import random
from typing import Any

from agv_app.layout.demo import demo_warehouse
from agv_app.tasks.desk import TaskDesk, pick_stations
from objectplaces.sim import SimulatedNetwork


def demo_desk(**options: Any) -> tuple[TaskDesk, SimulatedNetwork]:
    """The desk (``options`` go to ``TaskDesk``) and the network its stations are on."""
    layout = demo_warehouse()
    net = SimulatedNetwork(seed=1)
    desk = TaskDesk(layout, rng=random.Random(1), clock=lambda: net.now, **options)
    for sid in pick_stations(layout):
        desk.open_station(sid, net.add_node(f"st:{sid}"))
    return desk, net
