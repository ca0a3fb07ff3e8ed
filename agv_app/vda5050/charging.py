"""The vehicle's battery as VDA 5050 sees it: ``powerSupply``, startCharging, stopCharging.

The vehicles have no battery model yet. :class:`ConstantRateBattery` stands in for one:
a state of charge that stays where it is while the vehicle drives, and rises at a
constant rate while it charges, up to 100 %, where charging ends by itself. A vehicle
that offers a battery of its own (an attribute ``battery`` with the :class:`Battery`
interface) is reported and charged through that one instead (:func:`battery_of`).

Charging happens on a charging station of the layout only (:func:`charger_at`); the
vehicle that drives off its charger stops charging (``OrderAgv``).
"""

from __future__ import annotations

from typing import Any, Final, Protocol, runtime_checkable

from agv_app.layout.graph import Layout

__all__ = [
    "DEFAULT_CHARGE_RATE",
    "DEFAULT_STATE_OF_CHARGE",
    "Battery",
    "ConstantRateBattery",
    "battery_of",
    "charger_at",
    "power_supply",
]

DEFAULT_STATE_OF_CHARGE: Final = 80.0
"""Percent, where the stand-in battery starts."""

DEFAULT_CHARGE_RATE: Final = 0.5
"""Percent per second the stand-in battery gains while it charges."""


@runtime_checkable
class Battery(Protocol):
    """What the VDA 5050 interface needs of a vehicle's battery (times: the vehicle's
    clock, seconds)."""

    @property
    def charging(self) -> bool:
        """True while it charges."""
        ...

    def state_of_charge(self, now: float) -> float:
        """Percent, 0 to 100."""
        ...

    def start_charging(self, now: float) -> None:
        """Start charging (the vehicle stands on a charger)."""
        ...

    def stop_charging(self, now: float) -> None:
        """Stop charging."""
        ...


class ConstantRateBattery:
    """A battery that neither drains nor ages, and charges at a constant rate.

    Args:
        state_of_charge: percent at first.
        rate_percent_s: percent gained per second of charging.

    Raises:
        ValueError: a state of charge outside 0..100 or a rate that is not positive.
    """

    def __init__(
        self,
        *,
        state_of_charge: float = DEFAULT_STATE_OF_CHARGE,
        rate_percent_s: float = DEFAULT_CHARGE_RATE,
    ) -> None:
        if not 0.0 <= state_of_charge <= 100.0:
            raise ValueError(f"state_of_charge must be in 0..100, got {state_of_charge!r}")
        if not rate_percent_s > 0.0:
            raise ValueError(f"rate_percent_s must be positive, got {rate_percent_s!r}")
        self.rate_percent_s = rate_percent_s
        self._level = state_of_charge
        self._since: float | None = None

    @property
    def charging(self) -> bool:
        """True while it charges (it stops by itself when full, at the next look)."""
        return self._since is not None

    def state_of_charge(self, now: float) -> float:
        """Percent now; a full battery stops charging."""
        if self._since is None:
            return self._level
        level = min(100.0, self._level + (now - self._since) * self.rate_percent_s)
        if level >= 100.0:
            self._level, self._since = 100.0, None
        return level

    def start_charging(self, now: float) -> None:
        """Start charging (a full one stays full and does not charge)."""
        if self._since is None and self.state_of_charge(now) < 100.0:
            self._since = now

    def stop_charging(self, now: float) -> None:
        """Stop charging, keeping what it gained."""
        if self._since is not None:
            self._level = self.state_of_charge(now)
            self._since = None


def battery_of(vehicle: object) -> Battery:
    """The battery of ``vehicle``: its own (attribute ``battery``) if it has one with the
    :class:`Battery` interface, else a fresh :class:`ConstantRateBattery`."""
    own = getattr(vehicle, "battery", None)
    return own if isinstance(own, Battery) else ConstantRateBattery()


def charger_at(layout: Layout, point: str) -> str | None:
    """The charging station at ``point`` (None: no charger there)."""
    return next(
        (
            s.id
            for s in sorted(layout.stations.values(), key=lambda s: s.id)
            if s.point == point and s.kind == "charging"
        ),
        None,
    )


def power_supply(battery: Battery, now: float) -> dict[str, Any]:
    """The state's ``powerSupply`` object."""
    return {
        "stateOfCharge": round(battery.state_of_charge(now), 2),
        "charging": battery.charging,
    }
