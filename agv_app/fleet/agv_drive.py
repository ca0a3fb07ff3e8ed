"""An AGV process's run loop: it steps its vehicle every ``--dt`` of real time and
notes how late each step ran (:class:`StepLag`).
"""

from __future__ import annotations

import argparse
import asyncio
import random
from collections.abc import Callable
from typing import Any

from agv_app.fleet.agv_display import DisplayPublisher
from agv_app.fleet.agv_events import emit
from agv_app.fleet.restart_state import TaskKeeper
from agv_app.fleet.trace import VehicleTrace
from agv_app.vehicle.battery_drain import BatteryDrain
from agv_app.vehicle.controller import AgvController

__all__ = ["MAX_LAG_S", "StepLag", "drive_steps"]

MAX_LAG_S = 1.0
"""Seconds behind its clock past which the loop carries on from now (no burst of steps);
the most a loaded machine delays a frame, as the interest radius allows for."""
_LAG_EVERY_S = 5.0


class StepLag:
    """How late the control steps ran: whether the process keeps real time."""

    __slots__ = ("late_steps", "max_lag_s", "steps")

    def __init__(self) -> None:
        self.steps = 0
        self.late_steps = 0
        self.max_lag_s = 0.0

    def note(self, lag_s: float, dt: float) -> None:
        """A step ran ``lag_s`` seconds after its time (late: by more than ``dt``)."""
        self.steps += 1
        self.late_steps += lag_s > dt
        self.max_lag_s = max(self.max_lag_s, lag_s)

    def fields(self) -> dict[str, Any]:
        """The figures, for the ``closed`` event."""
        return {"steps": self.steps, "late_steps": self.late_steps, "max_lag_s": self.max_lag_s}


async def drive_steps(
    agv: AgvController,
    display: DisplayPublisher,
    args: argparse.Namespace,
    lag: StepLag,
    trace: VehicleTrace | None = None,
    keeper: TaskKeeper | None = None,
    battery: Callable[[float], object] | None = None,
) -> None:
    """Step the AGV every ``dt`` of real time, noting how late each step ran, until its
    vehicle's driver fails; ``battery`` drains (and charges) its battery each step
    (default: it only drains, :class:`~agv_app.vehicle.battery_drain.BatteryDrain`)."""
    battery_step = BatteryDrain(agv).step if battery is None else battery
    loop = asyncio.get_running_loop()
    dt = args.dt
    # Processes started together would otherwise step (and publish) in lockstep.
    await asyncio.sleep(random.Random(args.seed).uniform(0.0, dt))
    next_step = loop.time()
    next_publish = next_step
    next_lag_report = next_step + _LAG_EVERY_S
    while True:
        lag.note(loop.time() - next_step, dt)
        agv.step(dt)
        battery_step(dt)
        if trace is not None:
            trace.step()
        if keeper is not None:
            keeper.note(agv)
        if agv.failed:
            return
        now = loop.time()
        if now >= next_lag_report:
            next_lag_report = now + _LAG_EVERY_S
            emit("lag", **lag.fields())
        if now >= next_publish:
            next_publish = now + args.publish_interval
            display.publish()
        next_step += dt
        if now - next_step > MAX_LAG_S:
            # Fallen far behind (a stalled machine): carry on from now, no burst of steps.
            next_step = now
        await asyncio.sleep(max(0.0, next_step - loop.time()))
