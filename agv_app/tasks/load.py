"""Task load: how often to create tasks so that a target share of what the fleet and its
floor carry is used.

A fleet of ``N`` vehicles carries at most ``N / T`` tasks per second, ``T`` a task's
mean free-flow time (:func:`~agv_app.tasks.free_flow.mean_task_seconds`); its floor at
most ``C``, what its busiest shared part lets through: a two-way stretch, a station, a
station calling one AGV at a time (:func:`~agv_app.tasks.capacity.floor_capacity`,
:func:`fleet_floor_rules`). Load ``L`` makes tasks arrive at ``L * min(N / T, C)`` per
second. On a floor with room that is ``L * N / T``, and ``L * N`` vehicles are busy on
average; on a floor bound by one shared part (two two-way lanes crossing, a lane
between two areas, a few stations for many AGVs) more vehicles would only queue for it,
and the load is a share of what that part carries. Waiting
for locks makes real tasks longer than ``T``, so the share actually busy comes out a
little above ``L``. A run starts with about ``L * min(N, C * T)`` tasks at once (as many
as are busy at the load) so the fleet is at its load from the first seconds, not after
the first arrivals.
"""

from __future__ import annotations

import math
import random
from collections.abc import Callable

from agv_app.layout.graph import Layout
from agv_app.tasks.capacity import FREE_FLOW_RULES, FloorRules, floor_capacity
from agv_app.tasks.desk import drop_stations, pick_stations
from agv_app.tasks.free_flow import FreeFlowTimer, mean_task_seconds
from agv_app.vehicle.kinematics import VehicleSpec

__all__ = [
    "DEFAULT_LOAD",
    "TaskArrivals",
    "check_load",
    "fleet_floor_rules",
    "floor_vehicles",
    "initial_tasks",
    "standstill_pass",
    "task_interval_for_load",
]

DEFAULT_LOAD = 0.7
"""Share of the AGVs busy by default: a realistic load.

The demo warehouse carries it without a stall (no wait over 180 s, 12 AGVs, seeds 1-5,
30 simulated minutes; docs/fleet.md gives the figures), and a demo starts with about
``0.7 * N`` tasks, so most AGVs move within seconds."""


def check_load(load: float) -> float:
    """``load`` as a float if it is a share in (0, 1] (module docstring).

    Raises:
        ValueError: it is not a number in (0, 1].
    """
    if isinstance(load, bool) or not isinstance(load, int | float):
        raise ValueError(f"load must be a number in (0, 1], got {load!r}")
    if not (0.0 < load <= 1.0):
        raise ValueError(f"load must be in (0, 1] (the share of AGVs kept busy), got {load!r}")
    return float(load)


def standstill_pass(
    spec: VehicleSpec, *, t_update: float, step_s: float = 0.0
) -> Callable[[float], float]:
    """Seconds one pass holds a drive of so many metres, as a fleet drives it: from a
    standstill at ``spec``'s top speed and acceleration, then the handover of the floor
    to the next AGV (a release period ``t_update``, a voter's recheck ``t_update / 2``,
    a simulation step ``step_s``), as in the wait bound
    (:mod:`agv_app.traffic.wait_bound`)."""
    handover = 1.5 * t_update + step_s

    def hold(metres: float) -> float:
        return spec.travel_time(metres) + handover

    return hold


def fleet_floor_rules(
    spec: VehicleSpec,
    *,
    t_update: float,
    step_s: float = 0.0,
    one_at_a_time: bool = True,
    wait_for_drop: bool = True,
) -> FloorRules:
    """How a fleet of ``spec`` vehicles uses its floor (:class:`FloorRules`): every drive
    a :func:`standstill_pass`, the stations' rules as given (the fleets' defaults:
    both)."""
    return FloorRules(
        standstill_pass(spec, t_update=t_update, step_s=step_s),
        one_at_a_time=one_at_a_time,
        wait_for_drop=wait_for_drop,
    )


def floor_vehicles(
    layout: Layout, *, speed_m_s: float, dwell_s: float, rules: FloorRules = FREE_FLOW_RULES
) -> float:
    """How many vehicles ``layout`` keeps busy at most, whatever the fleet: what its
    busiest shared part carries times a task's mean free-flow time (``inf``: no shared
    part; ``rules``: how the fleet uses the floor,
    :func:`~agv_app.tasks.capacity.floor_capacity`).

    Raises:
        ValueError: a layout without pick and drop stations that reach each other.
    """
    timer = FreeFlowTimer(layout, speed_m_s, dwell_s)
    picks, drops = pick_stations(layout), drop_stations(layout)
    mean = mean_task_seconds(timer, picks, drops)
    return mean * floor_capacity(timer, picks, drops, rules).tasks_per_second


def task_interval_for_load(
    layout: Layout,
    *,
    agvs: int,
    load: float,
    speed_m_s: float,
    dwell_s: float,
    rules: FloorRules = FREE_FLOW_RULES,
    floor: float | None = None,
) -> float:
    """Mean seconds between new tasks at ``load`` of what ``agvs`` vehicles and
    ``layout`` carry, the less of the two (module docstring). ``floor``: how many
    vehicles the layout keeps busy, when the caller has it (``inf``: count the vehicles
    alone, past what the floor carries, for a run that means to make them queue);
    None: :func:`floor_vehicles` with ``rules``.

    Raises:
        ValueError: ``load`` outside (0, 1], ``agvs`` < 1, or a layout without
            pick and drop stations that reach each other.
    """
    load = check_load(load)
    if agvs < 1:
        raise ValueError(f"agvs must be at least 1, got {agvs!r}")
    timer = FreeFlowTimer(layout, speed_m_s, dwell_s)
    mean = mean_task_seconds(timer, pick_stations(layout), drop_stations(layout))
    if floor is None:
        floor = floor_vehicles(layout, speed_m_s=speed_m_s, dwell_s=dwell_s, rules=rules)
    return mean / (load * min(float(agvs), floor))


def initial_tasks(*, agvs: int, load: float, floor: float = math.inf) -> int:
    """Tasks to create at the start so that about ``load`` of ``agvs`` are busy at once,
    or of the ``floor`` vehicles the layout keeps busy (:func:`floor_vehicles`) if
    fewer."""
    return math.floor(check_load(load) * min(agvs, floor) + 0.5)


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
