"""Batteries and charging in the simulated fleet (``FleetConfig(batteries=...)``).

Every AGV gets a :class:`~agv_app.vehicle.battery.SimBattery` that drains as it drives
(metres its pose moved), handles loads (seconds it shows ``loading``) and runs (every
second). Below ``charge_below`` it takes no more tasks (the fleet keeps it out of
service: :meth:`Chargers.takes_tasks`) (it finishes the order it holds,
one awarded while it dwells included) and queues for a charger; chargers go to the
queue in order of need (first come, first served). The charger is claimed centrally,
in the fleet's :class:`~agv_app.fleet.parking.ParkingPlan`, as a rest point is: no two
AGVs own one at a time (the rule, shared with a fleet of AGV processes:
:class:`~agv_app.fleet.charge_rule.ChargeQueue`). The AGV's home becomes the
charger, so it drives there through the traffic protocol as it would drive home. On
it, it charges up to ``charge_to``, then gives the charger up for the nearest free rest
point and takes tasks again.

At 0 % an AGV stops where it is (held: it brakes and keeps its locks), shows ``empty``
and raises an alarm (:attr:`Chargers.alarms`); it never moves again in the run.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

from agv_app.fleet.charge_rule import ChargeQueue, charger_points
from agv_app.fleet.parking import ParkingPlan
from agv_app.vehicle.battery import BatterySpec, SimBattery
from agv_app.vehicle.controller import AgvController

__all__ = ["ChargeStats", "Chargers", "charger_points", "on_charger"]


@dataclass(slots=True)
class ChargeStats:
    """What charging cost a run.

    Attributes:
        charges: charges begun.
        charging_seconds: AGV-seconds spent on a charger.
        ran_empty: AGVs that reached 0 %.
        min_state_of_charge: the lowest state of charge any AGV reached, percent.
        max_charger_wait: the longest an AGV waited for a charger to be granted, s.
        sessions: every charge: ``(charger point, AGV id, start, end)`` (end: inf while
            it charges).
    """

    charges: int = 0
    charging_seconds: float = 0.0
    ran_empty: int = 0
    min_state_of_charge: float = 100.0
    max_charger_wait: float = 0.0
    sessions: list[tuple[str, str, float, float]] = field(default_factory=list)

    def summary(self) -> dict[str, float]:
        """The figures, flat and JSON-ready."""
        return {
            "charges": self.charges,
            "charging_seconds": round(self.charging_seconds, 1),
            "ran_empty": self.ran_empty,
            "min_state_of_charge": round(self.min_state_of_charge, 2),
            "max_charger_wait": round(self.max_charger_wait, 1),
        }


class Chargers:
    """The AGVs' batteries and the layout's chargers, for a simulated fleet.

    Args:
        spec: the AGVs' battery.
        parking: the fleet's parking plan (chargers are claimed there).
        agvs: the AGVs, by id; each keeps the battery it has (``AgvController.battery``)
            or is given one of ``spec``.
        levels: each AGV's state of charge at first (default: ``spec.initial``).

    Raises:
        ValueError: the layout has no charger.
    """

    def __init__(
        self,
        spec: BatterySpec,
        parking: ParkingPlan,
        agvs: Mapping[str, AgvController],
        *,
        levels: Mapping[str, float] | None = None,
    ) -> None:
        self.spec = spec
        self.parking = parking
        self.rule = ChargeQueue(spec, parking, agvs)
        """Who must charge, the queue and the grants (shared with the process fleet)."""
        self.points = self.rule.points
        self.batteries: dict[str, SimBattery] = {}
        for agv_id, agv in agvs.items():
            level = None if levels is None else levels.get(agv_id)
            own = agv.battery
            if isinstance(own, SimBattery) and level is None:
                battery = own
            else:
                battery = SimBattery(spec, state_of_charge=level)
                agv.battery = battery
            self.batteries[agv_id] = battery
        self.stats = ChargeStats()
        self.alarms = self.rule.alarms
        """``(time, AGV id, message)`` for every AGV that ran empty."""
        self._last_xy: dict[str, tuple[float, float]] = {}
        self._session: dict[str, int] = {}

    # -- what the fleet asks --------------------------------------------------------------

    def takes_tasks(self, agv_id: str) -> bool:
        """False while the AGV needs, awaits or takes a charge, or ran empty."""
        return self.rule.takes_tasks(agv_id)

    def stays(self, agv_id: str) -> bool:
        """True while the AGV must not be moved to another rest point (bound for or on a
        charger, or empty)."""
        return self.rule.stays(agv_id)

    def empty(self, agv_id: str) -> bool:
        """True once the AGV ran empty."""
        return self.rule.empty(agv_id)

    def status(self, agv_id: str) -> str | None:
        """``charging``, ``to-charger`` (it finishes its order first, or waits for a
        charger) or ``empty``; None while it works."""
        return self.rule.status(agv_id)

    def state_of_charge(self, agv_id: str, now: float) -> float | None:
        """The AGV's state of charge now, percent (None: no such AGV)."""
        battery = self.batteries.get(agv_id)
        return None if battery is None else battery.state_of_charge(now)

    # -- stepping -------------------------------------------------------------------------

    def step(self, agv_id: str, agv: AgvController, dt: float, now: float) -> None:
        """Drain or charge one AGV for the step of ``dt`` that just ended at ``now``."""
        battery = self.batteries[agv_id]
        rule = self.rule
        state = rule.state[agv_id]
        pose = agv.vehicle.pose()
        last = self._last_xy.get(agv_id)
        self._last_xy[agv_id] = (pose.x, pose.y)
        if state == "empty" or agv.failed:
            return
        if state == "charging":
            self.stats.charging_seconds += dt
            if battery.state_of_charge(now) >= self.spec.charge_to or not battery.charging:
                self._charged(agv_id, agv, battery, now)
            return
        metres = 0.0 if last is None else math.hypot(pose.x - last[0], pose.y - last[1])
        loading = agv.display_status() == "loading"
        level = battery.drain(metres=metres, load_s=dt if loading else 0.0, idle_s=dt)
        stats = self.stats
        stats.min_state_of_charge = min(stats.min_state_of_charge, level)
        if rule.note(agv_id, level, now):
            stats.ran_empty += 1
            agv.hold()  # it stops where it stands, locks kept
        elif state == "to_charger" and on_charger(agv):
            battery.start_charging(now)
            rule.arrived(agv_id)
            stats.charges += 1
            self._session[agv_id] = len(stats.sessions)
            stats.sessions.append((agv.home, agv_id, now, math.inf))

    def grant(self, agvs: Mapping[str, AgvController], now: float) -> None:
        """Hand free chargers to the AGVs that need one, first come first served."""
        if not self.rule.queue:
            return
        homes = {a: agv.home for a, agv in agvs.items()}
        standing = {a: agv.point for a, agv in agvs.items()}
        for agv_id, charger in self.rule.grant(homes, standing, now):
            agvs[agv_id].home = charger  # it drives there as it drives home, once done
        self.stats.max_charger_wait = self.rule.max_wait

    # -- inside -----------------------------------------------------------------------------

    def _charged(self, agv_id: str, agv: AgvController, battery: SimBattery, now: float) -> None:
        """Stop charging, give the charger up for a free rest point, take tasks again."""
        battery.stop_charging(now)
        k = self._session.pop(agv_id)
        point, _, start, _ = self.stats.sessions[k]
        self.stats.sessions[k] = (point, agv_id, start, now)
        rest = self.rule.charged(agv_id, agv.home, agv.point)
        if rest is not None:
            agv.home = rest  # the charger is free once the AGV sets off


def on_charger(agv: AgvController) -> bool:
    """True once the AGV stands on its charger (its home) with no order."""
    return (
        agv.point == agv.home
        and agv.phase == "home"
        and agv.task is None
        and agv.pending_task is None
        and agv.vehicle.speed == 0.0
        and agv.vehicle.remaining() < 1e-6
    )
