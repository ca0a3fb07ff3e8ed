"""A vehicle's battery: drains as the vehicle drives and handles loads, charges on a charger.

:class:`BatterySpec` declares a vehicle type's battery (``VehicleSpec.battery``; None:
the vehicle has no battery model and never runs empty). :class:`SimBattery` is one
vehicle's battery: a state of charge in percent that falls by ``drain_per_m`` for every
metre driven, ``drain_per_load_s`` for every second of load handling and
``drain_idle_per_s`` for every other second, and rises by ``charge_per_s`` while it
charges, never below 0 nor above 100. It has the VDA 5050 ``Battery`` interface
(:mod:`agv_app.vda5050.charging`), so ``powerSupply`` reports it.

While it charges the charger powers the vehicle: drains are not counted.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["BatterySpec", "SimBattery"]


@dataclass(frozen=True, slots=True)
class BatterySpec:
    """A vehicle type's battery (percent of a full charge; metres and seconds).

    Attributes:
        drain_per_m: percent used per metre driven.
        drain_per_load_s: percent used per second of load handling (at a station).
        drain_idle_per_s: percent used per second otherwise (electronics, standing).
        charge_per_s: percent gained per second on a charger.
        charge_below: below this the vehicle finishes its order and goes to charge.
        charge_to: it charges up to this, then returns to service.
        initial: state of charge at first.
    """

    drain_per_m: float = 0.01
    drain_per_load_s: float = 0.02
    drain_idle_per_s: float = 0.001
    charge_per_s: float = 0.05
    charge_below: float = 25.0
    charge_to: float = 90.0
    initial: float = 100.0

    def __post_init__(self) -> None:
        for name in ("drain_per_m", "drain_per_load_s", "drain_idle_per_s"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"BatterySpec.{name} must be 0 or more, got {value!r}")
        if not (math.isfinite(self.charge_per_s) and self.charge_per_s > 0):
            rate = self.charge_per_s
            raise ValueError(f"BatterySpec.charge_per_s must be positive, got {rate!r}")
        if not 0.0 <= self.charge_below < self.charge_to <= 100.0:
            raise ValueError(
                "BatterySpec needs 0 <= charge_below < charge_to <= 100, got "
                f"{self.charge_below!r} and {self.charge_to!r}"
            )
        if not 0.0 <= self.initial <= 100.0:
            raise ValueError(f"BatterySpec.initial must be in 0..100, got {self.initial!r}")


class SimBattery:
    """One vehicle's battery as :class:`BatterySpec` declares it.

    Args:
        spec: the battery type.
        state_of_charge: percent at first (default: ``spec.initial``).

    Raises:
        ValueError: a state of charge outside 0..100.
    """

    __slots__ = ("_level", "_since", "spec")

    def __init__(self, spec: BatterySpec, *, state_of_charge: float | None = None) -> None:
        level = spec.initial if state_of_charge is None else state_of_charge
        if not 0.0 <= level <= 100.0:
            raise ValueError(f"state_of_charge must be in 0..100, got {level!r}")
        self.spec = spec
        self._level = float(level)
        self._since: float | None = None

    @property
    def charging(self) -> bool:
        """True while it charges (it stops by itself when full, at the next look)."""
        return self._since is not None

    @property
    def level(self) -> float:
        """Percent as last settled (while charging: when charging started)."""
        return self._level

    @property
    def empty(self) -> bool:
        """True at 0 %."""
        return self._since is None and self._level <= 0.0

    def state_of_charge(self, now: float) -> float:
        """Percent now; a full battery stops charging."""
        if self._since is None:
            return self._level
        level = min(100.0, self._level + (now - self._since) * self.spec.charge_per_s)
        if level >= 100.0:
            self._level, self._since = 100.0, None
        return level

    def drain(self, *, metres: float = 0.0, load_s: float = 0.0, idle_s: float = 0.0) -> float:
        """Use what driving ``metres``, handling loads for ``load_s`` and standing for
        ``idle_s`` takes (nothing while charging); the state of charge after, percent."""
        if self._since is None:
            spec = self.spec
            used = (
                max(0.0, metres) * spec.drain_per_m
                + max(0.0, load_s) * spec.drain_per_load_s
                + max(0.0, idle_s) * spec.drain_idle_per_s
            )
            self._level = max(0.0, self._level - used)
        return self._level

    def start_charging(self, now: float) -> None:
        """Start charging (a full one stays full and does not charge)."""
        if self._since is None and self._level < 100.0:
            self._since = now

    def stop_charging(self, now: float) -> None:
        """Stop charging, keeping what it gained."""
        if self._since is not None:
            self._level = self.state_of_charge(now)
            self._since = None
