"""Draining the battery of an AGV that runs on its own (an AGV process).

The simulated fleet drains every AGV's battery with its chargers
(:mod:`agv_app.fleet.chargers`); an AGV process has no such fleet around it, so
:class:`BatteryDrain` drains its own the same way at every control step: the metres its
pose moved, the seconds it shows ``loading``, and every second. Charging, and the stop
at 0 %, are the process's :class:`~agv_app.fleet.charge_listener.ChargeListener`'s.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from agv_app.vehicle.battery import SimBattery

if TYPE_CHECKING:
    from agv_app.vehicle.controller import AgvController

__all__ = ["BatteryDrain"]


class BatteryDrain:
    """Drains ``agv``'s :class:`~agv_app.vehicle.battery.SimBattery` step by step.

    Args:
        agv: the AGV (its ``battery`` None or not a ``SimBattery``: nothing is drained).
    """

    def __init__(self, agv: AgvController) -> None:
        self.agv = agv
        self._last: tuple[float, float] | None = None

    def step(self, dt: float) -> float | None:
        """Drain for the step of ``dt`` seconds that just ended; the state of charge after,
        percent (None: no battery to drain, or the AGV failed)."""
        agv = self.agv
        battery = agv.battery
        if not isinstance(battery, SimBattery) or agv.failed:
            return None
        pose = agv.vehicle.pose()
        last, self._last = self._last, (pose.x, pose.y)
        metres = 0.0 if last is None else math.hypot(pose.x - last[0], pose.y - last[1])
        loading = agv.display_status() == "loading"
        return battery.drain(metres=metres, load_s=dt if loading else 0.0, idle_s=dt)
