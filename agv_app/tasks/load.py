"""Task load: how often to create tasks so that a target share of the fleet is busy.

A fleet of ``N`` vehicles at load ``L`` keeps ``L * N`` of them busy on average. A
vehicle is busy for a task's time, at least its free-flow time ``T``
(:func:`~agv_app.tasks.free_flow.mean_task_seconds`), so tasks arrive at
``L * N / T`` per second: one every ``T / (L * N)`` seconds. Waiting for locks makes
real tasks longer than ``T``, so the share actually busy comes out a little above ``L``.
A run starts with about ``L * N`` tasks at once so the fleet is at its load from the
first seconds, not after the first arrivals.
"""

from __future__ import annotations

import math
import random

from agv_app.layout.graph import Layout
from agv_app.tasks.desk import drop_stations, pick_stations
from agv_app.tasks.free_flow import FreeFlowTimer, mean_task_seconds

__all__ = [
    "DEFAULT_LOAD",
    "TaskArrivals",
    "check_load",
    "initial_tasks",
    "task_interval_for_load",
]

DEFAULT_LOAD = 0.7
"""Share of the AGVs busy by default: a realistic load.

The demo warehouse carries it without a stall (no wait over 180 s, 12 AGVs, seeds 1-5,
30 simulated minutes; docs/fleet.md gives the figures), and a demo starts with about
``0.7 * N`` tasks, so most AGVs move within seconds."""


def check_load(load: float) -> float:
    """``load`` as a float if it is a share of busy AGVs in (0, 1].

    Raises:
        ValueError: it is not a number in (0, 1].
    """
    if isinstance(load, bool) or not isinstance(load, int | float):
        raise ValueError(f"load must be a number in (0, 1], got {load!r}")
    if not (0.0 < load <= 1.0):
        raise ValueError(f"load must be in (0, 1] (the share of AGVs kept busy), got {load!r}")
    return float(load)


def task_interval_for_load(
    layout: Layout, *, agvs: int, load: float, speed_m_s: float, dwell_s: float
) -> float:
    """Mean seconds between new tasks that keep ``load`` of ``agvs`` vehicles busy.

    Raises:
        ValueError: ``load`` outside (0, 1], ``agvs`` < 1, or a layout without
            pick and drop stations that reach each other.
    """
    load = check_load(load)
    if agvs < 1:
        raise ValueError(f"agvs must be at least 1, got {agvs!r}")
    timer = FreeFlowTimer(layout, speed_m_s, dwell_s)
    mean = mean_task_seconds(timer, pick_stations(layout), drop_stations(layout))
    return mean / (load * agvs)


def initial_tasks(*, agvs: int, load: float) -> int:
    """Tasks to create at the start so that about ``load`` of ``agvs`` are busy at once."""
    return math.floor(check_load(load) * agvs + 0.5)


class TaskArrivals:
    """When new tasks arrive: a Poisson stream, ``interval`` seconds apart on average.

    Args:
        interval: mean seconds between tasks.
        rng: draws the gaps.

    Raises:
        ValueError: ``interval`` is not a positive number.
    """

    def __init__(self, interval: float, rng: random.Random) -> None:
        if not (interval > 0 and math.isfinite(interval)):
            raise ValueError(
                f"task interval must be a positive number of seconds, got {interval!r}"
            )
        self.interval = interval
        self.rng = rng

    def next_after(self, now: float) -> float:
        """The time of the task after one at ``now``."""
        return now + self.rng.expovariate(1.0 / self.interval)
