"""Who must charge and who gets which charger: the rule both fleets follow.

:class:`ChargeQueue` keeps every AGV's charging state (``work``, ``needs`` a charger,
bound ``to_charger``, ``charging``, ``empty``) and the queue of those that need a
charger. An AGV whose state of charge falls below ``charge_below`` joins the queue;
chargers (the layout's :func:`charger_points`) go to the queue in order of need (first
come, first served) and are claimed in the fleet's
:class:`~agv_app.fleet.parking.ParkingPlan` as a rest point is, so no two AGVs own one
at a time, and none is handed out while an AGV still stands on it. Charged, an AGV gives
the charger up for the nearest free rest point. At 0 % it is ``empty`` for good and an
alarm is raised (:attr:`ChargeQueue.alarms`).

The simulated fleet (:mod:`agv_app.fleet.chargers`) and the control of a fleet of AGV
processes (:mod:`agv_app.fleet.mesh_charging`) both drive one; only where the state of
charge comes from, and how a grant reaches the AGV, differ.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping

from agv_app.fleet.parking import ParkingPlan
from agv_app.layout.graph import Layout
from agv_app.vehicle.battery import BatterySpec

__all__ = ["EMPTY_ALARM", "ChargeQueue", "charger_points"]

EMPTY_ALARM = "battery empty: stopped where it stands"
"""The alarm's text for an AGV that ran empty."""


def charger_points(layout: Layout) -> list[str]:
    """The distinct points of the layout's usable charging stations, in layout order."""
    usable = set(layout.usable_stations())
    points: list[str] = []
    for station in layout.stations_of_kind("charging"):
        if station.id in usable and station.point not in points:
            points.append(station.point)
    return points


class ChargeQueue:
    """The AGVs' charging states, the queue for chargers and the grants.

    Args:
        spec: the AGVs' battery (its thresholds).
        parking: the fleet's parking plan (chargers are claimed there, and are no rest
            points for idle AGVs from now on).
        agv_ids: the AGVs at first (more may be added).

    Raises:
        ValueError: the layout has no charger.
    """

    def __init__(self, spec: BatterySpec, parking: ParkingPlan, agv_ids: Iterable[str]) -> None:
        self.spec = spec
        self.parking = parking
        self.points = charger_points(parking.layout)
        if not self.points:
            raise ValueError(f"layout {parking.layout.name!r} has no charging station")
        parking.set_aside(self.points)
        self.state: dict[str, str] = dict.fromkeys(agv_ids, "work")
        """Each AGV's state: ``work``, ``needs``, ``to_charger``, ``charging``, ``empty``."""
        self.alarms: list[tuple[float, str, str]] = []
        """``(time, AGV id, message)`` for every AGV that ran empty."""
        self.max_wait = 0.0
        """The longest an AGV waited for a charger to be granted, s."""
        self.queue: list[str] = []
        """The AGVs that need a charger, first in line first."""
        self._need_since: dict[str, float] = {}

    def add(self, agv_id: str) -> None:
        """A new AGV, at work (one already known keeps its state)."""
        self.state.setdefault(agv_id, "work")

    # -- what the fleet asks ----------------------------------------------------------------

    def takes_tasks(self, agv_id: str) -> bool:
        """False while the AGV needs, awaits or takes a charge, or ran empty."""
        return self.state.get(agv_id, "work") == "work"

    def stays(self, agv_id: str) -> bool:
        """True while the AGV must not be moved to another rest point (bound for or on a
        charger, or empty)."""
        return self.state.get(agv_id, "work") in ("to_charger", "charging", "empty")

    def empty(self, agv_id: str) -> bool:
        """True once the AGV ran empty."""
        return self.state.get(agv_id) == "empty"

    def status(self, agv_id: str) -> str | None:
        """``charging``, ``to-charger`` (it finishes its order first, or waits for a
        charger) or ``empty``; None while it works."""
        state = self.state.get(agv_id, "work")
        if state == "charging":
            return "charging"
        if state in ("needs", "to_charger"):
            return "to-charger"
        return "empty" if state == "empty" else None

    # -- what happens -----------------------------------------------------------------------

    def note(self, agv_id: str, level: float, now: float) -> bool:
        """The AGV's state of charge is ``level`` percent at ``now`` (it drains): at 0 %
        it ran empty, below ``charge_below`` at work it queues for a charger.

        Returns:
            True if it ran empty just now.
        """
        state = self.state.setdefault(agv_id, "work")
        if state in ("empty", "charging"):
            return False
        if level <= 0.0:
            self.ran_empty(agv_id, now)
            return True
        if state == "work" and level < self.spec.charge_below:
            self.state[agv_id] = "needs"
            self.queue.append(agv_id)
            self._need_since[agv_id] = now
        return False

    def grant(
        self, homes: Mapping[str, str], standing: Mapping[str, str], now: float
    ) -> list[tuple[str, str]]:
        """Hand free chargers to the AGVs in the queue, first come first served.

        Args:
            homes: each AGV's home (the rest point it owns).
            standing: the point each AGV stands at (or nearest to).
            now: the fleet's time.

        Returns:
            ``(AGV id, charger point)`` for every grant, in order; each AGV's home is to
            become its charger.
        """
        granted: list[tuple[str, str]] = []
        # A charger someone still stands on (about to leave it) is not free yet.
        free = [p for p in self.points if p not in set(standing.values())]
        while self.queue:
            agv_id = self.queue[0]
            home = homes[agv_id]
            charger = self.parking.relocate(agv_id, home, standing.get(agv_id, home), among=free)
            if charger is None:
                break  # none free: the first in line gets the next one
            self.queue.pop(0)
            free.remove(charger)
            self.state[agv_id] = "to_charger"
            self.max_wait = max(self.max_wait, now - self._need_since.pop(agv_id, now))
            granted.append((agv_id, charger))
        return granted

    def arrived(self, agv_id: str) -> None:
        """The AGV stands on its charger and charges."""
        if self.state.get(agv_id) == "to_charger":
            self.state[agv_id] = "charging"

    def charged(self, agv_id: str, charger: str, at: str) -> str | None:
        """The AGV charged to ``charge_to`` on ``charger`` and stands at ``at``: it gives
        the charger up and takes tasks again.

        Returns:
            The nearest free rest point, its new home (None: none free, it keeps the
            charger as its home).
        """
        if self.state.get(agv_id) == "empty":
            return None
        self.state[agv_id] = "work"
        return self.parking.relocate(agv_id, charger, at)

    def ran_empty(self, agv_id: str, now: float) -> None:
        """The AGV reached 0 %: it is ``empty`` for good, and the alarm is raised."""
        if self.state.get(agv_id) == "empty":
            return
        self.state[agv_id] = "empty"
        if agv_id in self.queue:
            self.queue.remove(agv_id)
        self._need_since.pop(agv_id, None)
        self.alarms.append((now, agv_id, EMPTY_ALARM))
